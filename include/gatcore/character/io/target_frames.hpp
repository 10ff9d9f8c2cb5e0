#pragma once
// Per-frame target meshes read from files: what a studio's own deformer
// stack baked (muscle / cloth simulation, sculpted correctives, a production
// rig), as training and evaluation targets for DenseGATs instead of a
// built-in reference deformer.
//
// Two layouts are read back:
// - point caches (.pc2, bake.hpp): a single file with one point per file
//   vertex (every primitive of the character concatenated, the layout
//   `gat deform --point-cache` wrote first), or several files, one per mesh
//   or primitive, given in the order of the character's primitives, whose
//   point counts add up to the file's vertices (one file per mesh);
// - a glTF whose morph-target animation holds the deformed frames (the
//   layout `gat deform -o OUT.glb` writes, bake.hpp): every frame is one
//   morph target per primitive, shown alone (weight 1) at one key of the
//   animation; the frame is the primitive's POSITION plus that target.
// Positions are the character file's world frame (what gat deform writes).
// File vertices are averaged into their welded vertex.
#include <string>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

struct TargetFrames {
  std::string source;  // for messages
  // [frames][3 * welded vertices of the character], world frame.
  std::vector<std::vector<float>> positions;
  // Where frame 0 sits on the source's timeline: the .pc2 start frame (gat
  // deform --frames A:B writes A) and frames per sample; a glTF's keys are
  // numbered from 0 by their time x the animation's key rate.
  double start_frame = 0.0, frame_step = 1.0;
};

// Throws InvalidArgument naming the file(s) and the problem: point counts
// that do not match the character's file vertices (per file when several
// files match primitive boundaries), no samples, non-finite points, or
// differing sample counts between the files.
TargetFrames read_point_cache_frames(const Character& ch, const std::vector<std::string>& paths);
// `animation`: the animation's name; empty: the one named "deform", else the
// only animation that animates morph weights. Throws for a file that does
// not match the character's primitives, an animation whose keys do not show
// exactly one target each, or targets without POSITION.
TargetFrames read_morph_target_frames(const Character& ch, const std::string& path, const std::string& animation = {});
// By extension: .pc2 (a comma-separated list of .pc2 files for one cache per
// mesh) or .glb / .gltf.
TargetFrames read_target_frames(const Character& ch, const std::string& spec, const std::string& animation = {});

}  // namespace gatcore::character
