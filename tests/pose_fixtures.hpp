#pragma once
// Seeded test poses for the deformer tests (test_runtime,
// test_character_nearest_joints): every joint turned, the root moved and
// turned (so the root-frame path of the features is exercised), and the
// joints' global matrices packed as the runtime takes them.
#include <cmath>
#include <vector>

#include "gatcore/character/rig/motion.hpp"

namespace posefix {

inline gatcore::character::Pose test_pose(const gatcore::character::Skeleton& s, int seed) {
  using namespace gatcore::character;
  Pose p = bind_pose(s);
  for (std::size_t j = 0; j < p.local.size(); ++j) {
    const float a = 0.3f * std::sin(float(seed * 7 + int(j) * 3));
    p.local[j].rotation = quat_normalize(quat_mul(p.local[j].rotation, quat_from_axis_angle({0.3f, 1.f, 0.2f}, a)));
  }
  p.local[0].translation[0] += 0.2f * float(seed);
  p.local[0].translation[2] -= 0.1f * float(seed);
  return p;
}

// [16 J] column-major global transforms, the runtime's per-frame input.
inline std::vector<float> globals_of(const gatcore::character::Skeleton& s, const gatcore::character::Pose& p) {
  std::vector<float> out;
  for (const auto& m : gatcore::character::global_transforms(s, p)) out.insert(out.end(), m.begin(), m.end());
  return out;
}

}  // namespace posefix
