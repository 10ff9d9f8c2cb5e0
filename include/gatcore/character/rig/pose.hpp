#pragma once
// A pose: one local transform per joint (relative to the parent joint, or to
// Skeleton::root_parent for roots), plus the global matrices it implies.
#include <string>
#include <vector>

#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

struct Pose {
  std::vector<Transform> local;  // [num_joints]
};

// The file's rest pose (node transforms).
Pose rest_pose(const Skeleton& s);
// The pose in which the skeleton's joints sit at their bind transforms
// (inverse of inverse_bind): skinning it reproduces the bind mesh exactly.
Pose bind_pose(const Skeleton& s);
// Joint-to-world matrices of a pose.
std::vector<Mat4> global_transforms(const Skeleton& s, const Pose& p);
// global * inverse_bind per joint: what skinning applies to bind-space vertices.
std::vector<Mat4> skinning_matrices(const Skeleton& s, const Pose& p);

// An animation sampled at a fixed rate.
struct Clip {
  std::string name;
  float fps = 30.0f;
  std::vector<Pose> frames;
};

// Most joint transforms an imported clip may hold (frames x joints, about
// 335 MB): an hour at 30 fps of a 77-joint rig. A file's animation ends
// where its last key time says; a small file claiming years must not make
// the importer sample it.
inline constexpr std::int64_t kMaxClipJointSamples = std::int64_t(1) << 23;
// Frames of a clip `duration_s` long sampled at `fps` (both ends), for a rig
// of `joints`; throws InvalidArgument naming `what` for a duration that is
// negative or not finite, or a clip past kMaxClipJointSamples.
int clip_frame_count(double duration_s, double fps, std::int32_t joints, const std::string& what);

}  // namespace gatcore::character
