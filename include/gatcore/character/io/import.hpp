#pragma once
// Character import by file type: glTF (.glb / .gltf) through tinygltf, every
// other format assimp reads (FBX, Collada, ...) through assimp.
#include <string>

#include "gatcore/character/io/gltf.hpp"

namespace gatcore::character {

using ImportOptions = GltfImportOptions;

// Same contract as load_gltf: one character, one skeleton (the bones of all
// skinned meshes plus the nodes between them), welded, weights renormalised,
// clips sampled at opt.clip_fps; InvalidArgument naming the file and the
// problem otherwise. Meshes whose bones' offset matrices differ (FBX: one bind
// space per mesh) are brought into the first mesh's bind space.
Character load_assimp_character(const std::string& path, const ImportOptions& opt = {});

// Dispatches on the extension (.glb / .gltf: load_gltf; anything else:
// load_assimp_character).
Character load_character(const std::string& path, const ImportOptions& opt = {});

}  // namespace gatcore::character
