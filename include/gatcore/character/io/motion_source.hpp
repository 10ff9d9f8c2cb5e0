#pragma once
// One entry point for a motion a user brings, whatever holds it: a BVH file,
// an Acclaim ASF/AMC pair (the CMU database's own format), or an animation
// clip of a glTF / FBX / Collada character (to drive another character
// with). Every source gives the same Motion, so the retargeter
// (rig/motion.hpp) takes them all.
#include <string>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/progress.hpp"

namespace gatcore::character {

struct MotionLoadOptions {
  float clip_fps = 30.0f;  // rate a glTF / FBX clip is sampled at
  float amc_fps = 0.0f;    // an AMC file's frame rate (AMC stores none; 0: 120, the CMU rate)
  WarningFn warn;          // lenient reads say what they assumed here (stderr without one)
};

// spec, by file type (extensions in any case):
//   walk.bvh                  BVH (io/bvh.hpp)
//   walk.amc                  AMC, its skeleton the .asf beside it: walk.asf, else
//                             the CMU naming (02_01.amc -> 02.asf), else the only
//                             .asf in the folder
//   skel.asf:walk.amc         AMC with the skeleton named
//   other.glb[#clip]          a clip of a character file (.glb .gltf .fbx .dae and
//   other.fbx[#3]             whatever assimp reads): by name, or by index from 0;
//                             without '#', the first clip
// Throws InvalidArgument naming the file: unreadable or malformed files (the
// readers' own errors), an unknown extension, an AMC without a skeleton (the
// places looked in), a character file without animations (a file without a
// skinned mesh reads its animated nodes as the skeleton), a clip not found
// (listing the clips the file has).
Motion load_motion(const std::string& spec, const MotionLoadOptions& options = {});

// What `gat info` prints for a motion: the convention and up axis the
// retargeter reads (map_motion_rig), each canonical body part with its joint,
// the helpers and the joints it ignores.
std::string describe_motion_rig(const Motion& motion, const BoneAliases& aliases = {});

}  // namespace gatcore::character
