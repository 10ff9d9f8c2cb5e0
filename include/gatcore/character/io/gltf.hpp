#pragma once
// glTF 2.0 import (.gltf / .glb) through tinygltf.
#include <string>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

struct GltfImportOptions {
  // Vertices closer than this fraction of the bounding-box diagonal are
  // welded into one (UV / material seams store them twice).
  float weld_tolerance = 1e-6f;
  float clip_fps = 30.0f;  // sampling rate of the file's animations
  bool load_clips = true;
  // External buffer / image URIs of a .gltf must resolve inside this folder
  // (empty: the model file's own folder); others ("../../etc/hostname", an
  // absolute path, a symlink out of it) are refused by name.
  std::string resource_root;
  // A file without skins (an animation exported without its character mesh)
  // is read as a character without a mesh: its skeleton the animated nodes
  // and the nodes between them, bound at their node transforms. Read by
  // load_motion; other callers need a mesh. (load_assimp_character too.)
  bool allow_no_skin = false;
};

// Merges every skinned primitive of every mesh instance in the file (several
// meshes, primitives, skins) into one character with one skeleton: the union
// of the skins' joints plus the nodes between them. Weights are renormalised;
// disjoint components, non-manifold parts and weightless joints are kept.
// Throws InvalidArgument naming the file and the problem for unreadable,
// truncated or malformed files, files without a skin, weights referencing
// missing joints, and non-finite data.
Character load_gltf(const std::string& path, const GltfImportOptions& opt = {});

// Writes the glTF file `source_path` (from which `ch` was loaded) to
// `out_path` (.glb: binary, .gltf: JSON with embedded buffers) with every
// skinned primitive's JOINTS_n / WEIGHTS_n replaced by `weights` (one row
// per welded vertex of `ch`, skeleton joint ids; each file vertex takes its
// welded vertex's `max_influences` largest weights, renormalised, written in
// sets of 4: JOINTS_0/WEIGHTS_0, JOINTS_1/WEIGHTS_1, ...). Joints missing from
// a primitive's skin are appended to it (with their inverse bind matrices).
// Everything else in the file (nodes, materials, images, animations, other
// attributes) is kept; the old weight accessors stay, unused. The write is
// atomic (temp file + rename).
void save_gltf_with_weights(const std::string& source_path, const Character& ch, const SkinWeights& weights,
                            const std::string& out_path, int max_influences = 4);

// Writes a character held only in memory (e.g. procedural_character) as a
// new glTF file: one mesh node with the welded mesh (POSITION, NORMAL,
// JOINTS_n / WEIGHTS_n), one node per joint with its rest transform (a root's
// non-identity root_parent becomes a parent node), one skin with the inverse
// bind matrices; each of ch.clips as an animation (a linear key per frame,
// every joint's translation and rotation). load_gltf reads it back as the
// same character. Atomic.
void save_gltf_character(const Character& ch, const std::string& out_path);

}  // namespace gatcore::character
