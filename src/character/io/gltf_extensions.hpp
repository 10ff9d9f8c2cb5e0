#pragma once
// Internal: glTF extensions that change how a file's bytes are read. Every
// glTF read goes through load_gltf_model: it refuses a file that requires an
// extension gatcore cannot read (by name), and decodes compressed geometry
// (KHR_draco_mesh_compression through Google's libdraco, the reference
// decoder; EXT_meshopt_compression through libmeshoptimizer, the format
// author's library) into plain buffer views, so the rest of the importer
// never sees a placeholder buffer.
#include <string>

#include <tiny_gltf.h>

namespace gatcore::character::gltf_ext {

// Loads `path` (.glb when `binary`, else .gltf) like tinygltf's
// LoadBinaryFromFile / LoadASCIIFromFile: false with *err for files tinygltf
// cannot read. Throws InvalidArgument naming the file for an unsupported
// required extension or compressed data that does not decode. On return the
// model has no compression extensions left (extensionsUsed / Required
// updated), so writing it back gives a plain glTF file.
bool load_gltf_model(tinygltf::TinyGLTF& loader, tinygltf::Model* model, std::string* err, std::string* warn,
                     const std::string& path, bool binary);

// The required extensions load_gltf_model accepts.
const char* supported_required_extensions();

}  // namespace gatcore::character::gltf_ext
