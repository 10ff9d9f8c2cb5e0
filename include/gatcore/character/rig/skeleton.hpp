#pragma once
// A joint hierarchy: parents before children (parent[j] < j, -1 for roots).
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character {

struct Skeleton {
  std::vector<std::string> names;
  std::vector<std::int32_t> parents;      // -1 for a root; otherwise < j
  std::vector<Transform> rest_local;      // the file's node transforms (rest pose)
  std::vector<Mat4> inverse_bind;         // bind space -> joint space (glTF inverseBindMatrices)
  // For a root joint: the global transform of its non-joint ancestors in the
  // file (e.g. an armature node scaled by 0.01); identity for other joints.
  std::vector<Mat4> root_parent;

  std::int32_t num_joints() const { return static_cast<std::int32_t>(names.size()); }
  std::int32_t find(const std::string& name) const;  // -1 if absent
  std::vector<std::vector<std::int32_t>> children() const;
  void validate(const char* what = "skeleton") const;
};

}  // namespace gatcore::character
