#pragma once
// Internal helpers shared by the glTF writers (weights, whole characters,
// baked morph-target animations): reading a source file back, appending
// accessors to buffer 0, node matrices, and atomic writes.
#include <cstddef>
#include <string>
#include <vector>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character::gltf_util {

bool is_glb(const std::string& path);
// Reads a .glb / .gltf without decoding images; throws naming the file.
tinygltf::Model read_model(const std::string& path);
// Accessor `accessor` as count x comps finite floats (any component type,
// strides, sparse); throws naming `file` and `what` (implemented with the
// importer's reader in gltf.cpp).
std::vector<float> read_floats(const tinygltf::Model& m, int accessor, int comps, const std::string& what,
                               const std::string& file);
// Appends `bytes` as a new buffer view of buffer 0 and an accessor over it.
int append_accessor(tinygltf::Model& m, const void* data, std::size_t bytes, int component_type, int type,
                    std::size_t count);
// Float VEC3 accessor with the min / max glTF requires for POSITION data.
int append_vec3(tinygltf::Model& m, const std::vector<float>& xyz);
// The node's local transform (TRS, rotation normalised; a matrix decomposed).
Transform node_local(const tinygltf::Node& n);
// The node's local matrix (its matrix as written, else TRS).
Mat4 node_matrix(const tinygltf::Node& n);
// Global rest matrices of every node (throws on cycles / bad children).
std::vector<Mat4> node_globals(const tinygltf::Model& m, const std::string& file);
// Serialises `m` in memory (binary for .glb, JSON with embedded buffers
// otherwise), checks that tinygltf wrote it whole, then writes it with
// write_file_atomic: a failed write (full disk, ...) leaves no partial file
// and is an error (tinygltf's own file writer ignores stream errors).
void write_model_atomic(tinygltf::Model& m, const std::string& path);

// Makes `loader` read external buffer / image URIs only inside `root`
// (empty: the folder of `model_path`); the model file itself is always
// allowed. A URI resolving elsewhere ("../../etc/hostname", an absolute
// path, a symlink out) is refused by name. `guard` holds the state the
// callbacks use and must outlive the load.
struct ResourceGuard {
  std::string model, root;  // canonical
};
void confine_resources(tinygltf::TinyGLTF& loader, ResourceGuard& guard, const std::string& model_path,
                       const std::string& root = {});

}  // namespace gatcore::character::gltf_util
