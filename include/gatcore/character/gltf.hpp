#pragma once
// glTF 2.0 import (.gltf / .glb) through tinygltf.
#include <string>

#include "gatcore/character/character.hpp"

namespace gatcore::character {

struct GltfImportOptions {
  // Vertices closer than this fraction of the bounding-box diagonal are
  // welded into one (UV / material seams store them twice).
  float weld_tolerance = 1e-6f;
  float clip_fps = 30.0f;  // sampling rate of the file's animations
  bool load_clips = true;
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
// skinned primitive's JOINTS_0 / WEIGHTS_0 replaced by `weights` (one row
// per welded vertex of `ch`, skeleton joint ids; each file vertex takes its
// welded vertex's 4 largest weights, renormalised). Joints missing from a
// primitive's skin are appended to it (with their inverse bind matrices).
// Everything else in the file (nodes, materials, images, animations, other
// attributes) is kept; the old weight accessors stay, unused.
void save_gltf_with_weights(const std::string& source_path, const Character& ch, const SkinWeights& weights,
                            const std::string& out_path);

}  // namespace gatcore::character
