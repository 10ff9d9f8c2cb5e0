#pragma once
// Motion capture on a skeleton: retargeting onto a character skeleton by
// joint names with rest-pose alignment, and random poses within per-joint
// limits (the papers' "random poses"). Reading BVH files: io/bvh.hpp.
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

// A motion: its own skeleton (rest = the file's offsets, zero rotations; its
// inverse bind matrices are the inverse rest globals) and one clip.
struct Motion {
  std::string name;  // file name
  Skeleton skeleton;
  Clip clip;
};


// Source joint name -> target joint name.
struct RetargetMap {
  std::vector<std::pair<std::string, std::string>> pairs;
  // CMU BVH (Hips, LowerBack, Spine, Spine1, Neck, Head, LeftShoulder, LeftArm,
  // LeftForeArm, LeftHand, LeftUpLeg, LeftLeg, LeftFoot, ...) to the common
  // humanoid names of the Quaternius rigs (Hips, Abdomen, Torso, Chest, Neck,
  // Head, Shoulder.L, UpperArm.L, LowerArm.L, Hand.L, UpperLeg.L, LowerLeg.L,
  // Foot.L, ...).
  static RetargetMap cmu_to_humanoid();
};

// The bind pose expressed in the world frame of the rest pose: skinning it
// gives bind_to_world applied to the bind mesh (e.g. undoing FBX2glTF's Z-up
// x100 bind space). bind_to_world: NormalisationStats::bind_to_world.
Pose world_bind_pose(const Skeleton& s, const Mat4& bind_to_world);

// Retargets `motion` onto `target`: every mapped target joint takes the
// source joint's world rotation change from its rest, applied after aligning
// the target's bind bone direction with the source's rest bone direction
// (rest-pose alignment: a target A-pose follows a source T-pose); unmapped
// joints keep their bind rotation relative to their parent. The first mapped
// pair (the hips) also carries the root translation, scaled by the ratio of
// rest hip heights above the lowest joint: vertically above the target's
// ground (its lowest bind joint) as the source hips are above the lowest any
// source joint goes in the clip; horizontally from the target's rest place,
// as the source hips moved since the first frame. Needs >= 1 mapped pair.
Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world,
              const RetargetMap& map = RetargetMap::cmu_to_humanoid());

// Per-joint rotation limits as XYZ Euler angles (radians) around the rest
// rotation.
struct JointLimit {
  Vec3 lo{0.0f, 0.0f, 0.0f}, hi{0.0f, 0.0f, 0.0f};
};
// +-max_angle on every axis for every joint except roots (kept at rest).
std::vector<JointLimit> uniform_limits(const Skeleton& s, float max_angle);
// A pose with each joint's local rotation = rest * Rx Ry Rz, angles uniform
// within its limits; deterministic for a given generator state.
Pose random_pose(const Skeleton& s, const Pose& rest, const std::vector<JointLimit>& limits, std::mt19937& rng);

}  // namespace gatcore::character
