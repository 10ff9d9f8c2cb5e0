#pragma once
// A dataset character's file targets (DatasetDescription::targets) made into
// its reference deformer: the frames read back (io/target_frames.hpp), each
// paired with its pose of the driving motion by the frame map, and checked.
#include <string>

#include "gatcore/character/data/dataset.hpp"

namespace gatcore::character {

struct FileTargetSummary {
  std::int32_t frames = 0;
  double first_frame = 0, step = 1;  // motion frame of target frame k: first_frame + k * step
  std::int64_t motion_frames = 0;    // of the driving motion
  double mean_to_lbs = 0, max_to_lbs = 0;  // target vs LBS of its pose, world units (mean over frames / max)
};

// Reads src's frames for `pc` (prepared from `file_character`, the character
// as loaded from its file: the file-vertex map), resolves the driving motion
// (a BVH retargeted onto the character, or "clip:NAME" / "clip": one of the
// file's own animations), and sets pc.reference (file targets) and
// pc.target_poses. Throws InvalidArgument naming `what` and the problem:
// vertex counts (the readers), a frame map that is not integral or runs past
// the motion's frames, or targets so far from LBS of their poses (mean over
// the mesh above 0.1 x the character's height) that they cannot belong to
// those poses (wrong motion, frame map, up axis or units).
FileTargetSummary attach_file_targets(PreparedCharacter& pc, const Character& file_character,
                                      const FileTargetSource& src, const std::string& what);

}  // namespace gatcore::character
