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

}  // namespace gatcore::character
