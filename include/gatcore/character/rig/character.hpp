#pragma once
// A rigged character: one welded mesh, one skeleton, the map back to the
// file's vertices (for exports) and the file's animations.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/rig/mesh.hpp"
#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

// One primitive of the source file: its vertices are file vertices
// [first_vertex, first_vertex + num_vertices) of the concatenation.
struct SourcePrimitive {
  std::int32_t mesh = 0;       // glTF mesh index
  std::int32_t primitive = 0;  // primitive index within the mesh
  std::int32_t node = 0;       // node that instantiates it
  // The object a DCC tool makes of that node: its name, or Blender's for an
  // unnamed glTF node ("Node_2"). Point caches are written per object.
  std::string object;
  std::int64_t first_vertex = 0;
  std::int64_t num_vertices = 0;
  // The primitive's own mesh space -> the character's bind space (where
  // Mesh::positions and Skeleton::inverse_bind live). Identity unless the
  // file binds its meshes with different skins whose inverse bind matrices
  // differ for the same joint (an exporter writing one skin per object,
  // relative to that object's transform): exports and morph targets go back
  // through it.
  Mat4 to_bind = mat4_identity();
};

struct Character {
  std::string name;                       // file name (for messages)
  Mesh mesh;                              // welded
  Skeleton skeleton;
  std::vector<std::int32_t> welded_from_file;  // [file vertices] -> welded vertex id
  std::vector<SourcePrimitive> primitives;
  std::vector<std::int32_t> joint_nodes;  // [joints] the file node of each joint (-1: none)
  std::vector<Clip> clips;

  std::int64_t num_file_vertices() const { return static_cast<std::int64_t>(welded_from_file.size()); }
};

}  // namespace gatcore::character
