#pragma once
// What the deformer tests (test_runtime, test_character_nearest_joints)
// deform: a small procedural humanoid, seeded test poses (every joint
// turned, the root moved and turned, so the root-frame path of the features
// is exercised), the joints' global matrices packed as the runtime takes
// them, and a character moved to other units and another place.
#include <cmath>
#include <vector>

#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/rig/motion.hpp"

namespace posefix {

// About 2.5k vertices, 19 joints.
inline gatcore::character::Character humanoid(std::uint32_t seed) {
  gatcore::character::ProceduralOptions o;
  o.seed = seed;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  return gatcore::character::procedural_character(o);
}

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

// The same character in centimetres, somewhere else: what an FBX from
// Mixamo or an Unreal export is next to a glTF in metres. Bind space, joint
// bind matrices and the roots' rest transforms all move by m; the joints'
// local transforms are relative and stay.
inline gatcore::character::Character moved_and_scaled(const gatcore::character::Character& c, float s,
                                                     gatcore::character::Vec3 t) {
  using namespace gatcore::character;
  Mat4 m = mat4_identity();
  m[0] = m[5] = m[10] = s;
  m[12] = t[0];
  m[13] = t[1];
  m[14] = t[2];
  const Mat4 inv = inverse(m);
  Character out = c;
  for (std::size_t i = 0; i + 2 < out.mesh.positions.size(); i += 3) {
    const Vec3 p = transform_point(m, {c.mesh.positions[i], c.mesh.positions[i + 1], c.mesh.positions[i + 2]});
    out.mesh.positions[i] = p[0];
    out.mesh.positions[i + 1] = p[1];
    out.mesh.positions[i + 2] = p[2];
  }
  for (std::int32_t j = 0; j < out.skeleton.num_joints(); ++j) {
    out.skeleton.inverse_bind[std::size_t(j)] = mul(c.skeleton.inverse_bind[std::size_t(j)], inv);
    if (out.skeleton.parents[std::size_t(j)] < 0)
      out.skeleton.root_parent[std::size_t(j)] = mul(m, c.skeleton.root_parent[std::size_t(j)]);
  }
  return out;
}

// [16 J] column-major global transforms, the runtime's per-frame input.
inline std::vector<float> globals_of(const gatcore::character::Skeleton& s, const gatcore::character::Pose& p) {
  std::vector<float> out;
  for (const auto& m : gatcore::character::global_transforms(s, p)) out.insert(out.end(), m.begin(), m.end());
  return out;
}

}  // namespace posefix
