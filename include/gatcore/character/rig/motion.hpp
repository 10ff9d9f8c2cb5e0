#pragma once
// Motion capture on a skeleton: retargeting onto a character skeleton
// through the rig conventions (rig_convention.hpp) or explicit joint pairs,
// with rest-pose alignment, and random poses within per-joint limits (the
// papers' "random poses"). Reading BVH files: io/bvh.hpp.
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/character/rig/skeleton.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"

namespace gatcore::character {

// A motion: its own skeleton (rest = the file's offsets, zero rotations; its
// inverse bind matrices are the inverse rest globals) and one clip.
struct Motion {
  std::string name;  // file name
  Skeleton skeleton;
  Clip clip;
};


// Source joint name -> target joint name (an explicit pairing; the first
// pair is the hips and carries the root motion).
struct RetargetMap {
  std::vector<std::pair<std::string, std::string>> pairs;
  // CMU BVH (Hips, LowerBack, Spine, Spine1, Neck, Head, LeftShoulder, LeftArm,
  // LeftForeArm, LeftHand, LeftUpLeg, LeftLeg, LeftFoot, ...) to the common
  // humanoid names of the Quaternius rigs (Hips, Abdomen, Torso, Chest, Neck,
  // Head, Shoulder.L, UpperArm.L, LowerArm.L, Hand.L, UpperLeg.L, LowerLeg.L,
  // Foot.L, ...).
  static RetargetMap cmu_to_humanoid();
};

// How retarget pairs joints when no explicit map is given: both skeletons
// go through map_rig (rig_convention.hpp), so any known convention (or an
// unnamed rig the structural fallback reads) drives any other.
struct RetargetOptions {
  std::string target_name = "target skeleton";  // for messages (the character's file)
  BoneAliases source_aliases;  // normalised joint name -> body part or known joint name (--alias)
  BoneAliases target_aliases;
  // A target that is not a humanoid (a quadruped, a creature) is refused,
  // naming its unmapped limbs; with this set it gets the root motion only
  // (its limbs stay in the bind pose, by request).
  bool root_motion_only = false;
};

// The bind pose expressed in the world frame of the rest pose: skinning it
// gives bind_to_world applied to the bind mesh (e.g. undoing FBX2glTF's Z-up
// x100 bind space). bind_to_world: NormalisationStats::bind_to_world.
Pose world_bind_pose(const Skeleton& s, const Mat4& bind_to_world);

// How retarget reads a motion's skeleton: its map onto the canonical body
// and the rotation that stands it in the retargeter's world (Y up, facing
// +Z, its left at +X). The up axis and the facing come from the rest pose
// once the body is mapped (upper arms above thighs, left limbs on the
// left), snapped to the nearest axes, so Z-up captures (Vicon, 3ds Max,
// Blender exports) and captures facing another way are driven the same.
// Names are tried first; a skeleton they do not explain is read by its
// structure in each of the six axis-aligned up directions.
struct MotionRig {
  RigMapping mapping;
  Mat4 to_world = mat4_identity();  // the motion's world -> Y up, facing +Z (an axis permutation with signs)
  std::string frame;                // e.g. "Y up, facing +Z" or "Z up, facing -Y (turned to Y up, facing +Z)"
};
MotionRig map_motion_rig(const Skeleton& s, const BoneAliases& aliases = {});

// Retargets `motion` onto `target`: every mapped target joint takes the
// source joint's world rotation change from its rest, applied after aligning
// the target's bind bone direction with the source's rest bone direction
// (rest-pose alignment: a target A-pose follows a source T-pose); unmapped
// joints (helpers: twist, IK, end bones) keep their bind rotation relative to
// their parent. Spine and neck chains of different lengths are paired by
// their relative position along the chain; fingers only when both sides have
// them. A mapped joint that does not hang under its body parent (older
// Quaternius feet on the root) keeps its rest offset from that parent
// instead of stretching. The pelvis carries the root translation, scaled by
// the ratio of rest hip heights above the lowest joint: vertically above the
// target's ground (its lowest bind joint) as the source hips are above the
// lowest any source joint goes in the clip; horizontally from the target's
// rest place, as the source hips moved since the first frame; it is applied
// to the topmost ancestor of the target's pelvis (the rig's root).
// Throws InvalidArgument when either skeleton is not a humanoid (pelvis,
// thighs, shins, upper arms, forearms mapped), naming the missing parts and
// the unrecognised joints and suggesting --alias; see RetargetOptions for
// non-humanoid targets.
Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world,
              const RetargetOptions& options = {});
// With an explicit joint pairing (no convention detection). Needs >= 1 mapped pair.
Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world, const RetargetMap& map);

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
