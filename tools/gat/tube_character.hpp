#pragma once
// The embedded default data of the `gat demo` job: a procedurally generated
// two-bone tube ("an arm"), skinned with smooth weights across the elbow.
// Poses bend and twist the elbow; LBS collapses the joint (the candy-wrapper
// artefact) while the target, angle-blended skinning, keeps its volume. The
// network learns the per-vertex correction target − LBS, as DenseGATs does.
#include <array>
#include <cstdint>
#include <vector>

#include "gatcore/tensor.hpp"

namespace demo {

using Vec3 = std::array<float, 3>;

struct TubeCharacter {
  std::vector<Vec3> rest;               // rest positions
  std::vector<std::int32_t> triangles;  // 3 per triangle
  std::vector<float> elbow_weight;      // weight of bone 1 (bone 0 gets 1 - w)
  Vec3 elbow{0.f, 1.f, 0.f};
  std::array<Vec3, 3> joints{};         // shoulder, elbow, wrist (rest)
  std::int64_t num_vertices() const { return static_cast<std::int64_t>(rest.size()); }
};

struct Pose {
  float bend = 0.f;   // radians about x at the elbow
  float twist = 0.f;  // radians about the forearm's axis (y)
};

TubeCharacter make_tube(int rings = 24, int segments = 16, float radius = 0.25f);

// Per-vertex node features on the LBS-posed mesh: [position (3), area-weighted
// normal (3), distance to each of the 3 posed joints] -> [n, 9].
gatcore::Tensor node_features(const TubeCharacter& c, const std::vector<Vec3>& lbs, const Pose& p);
std::vector<Vec3> skin_lbs(const TubeCharacter& c, const Pose& p);
std::vector<Vec3> skin_target(const TubeCharacter& c, const Pose& p);  // angle-blended reference

}  // namespace demo
