#pragma once
// Baking a deformed animation for playback in other tools: glTF morph
// targets (one per frame) and point caches (.pc2).
//
// glTF layout written by save_gltf_morph_animation: the source file is kept
// as it is (skin, skeleton, materials, its own animations) and every skinned
// primitive of the character gets one morph target per frame whose POSITION
// delta takes the file's bind-space vertex to its deformed world position.
// A new animation (`name`) holds every joint at its bind transform (so
// skinning is the identity and the mesh shows bind + delta exactly: what was
// deformed, not LBS of it) and steps the mesh's morph weights (STEP
// interpolation) so that at time f / fps only target f has weight 1. The
// file's own animations still play the plain skinned character (morph
// weights default to 0).
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

struct BakedFrames {
  std::string name = "deform";  // the animation's name
  float fps = 30.0f;
  // Per frame: [3 * welded vertices] positions in the glTF world frame.
  std::vector<std::vector<float>> positions;
};

// Per file vertex (the concatenation of the character's primitives) the
// position of its welded vertex: [3 * num_file_vertices].
std::vector<float> file_vertex_positions(const Character& ch, const std::vector<float>& welded_positions);

// `source_path`: the glTF file `ch` was loaded from; `out_path`: .glb or
// .gltf. Atomic (temp file + rename). Throws InvalidArgument naming the file
// and the problem (no frames, sizes, a source that does not match `ch`).
void save_gltf_morph_animation(const std::string& source_path, const Character& ch, const BakedFrames& frames,
                               const std::string& out_path);

// Point cache (.pc2, read by Blender's Mesh Cache modifier, Maya, Houdini):
// "POINTCACHE2\0", int32 version 1, int32 points, float start frame, float
// sample rate (frames per sample), int32 samples, then samples x points x
// float32 xyz, little endian. One point per file vertex (file_vertex_positions).
struct PointCache {
  std::int32_t num_points = 0;
  float start_frame = 0.0f, sample_rate = 1.0f;
  std::vector<std::vector<float>> samples;  // [samples][3 * points]
};
void write_point_cache(const std::string& path, const PointCache& pc);  // atomic
PointCache read_point_cache(const std::string& path);  // throws naming the file for bad / truncated files

// The up axis of written points: y keeps the file's frame (glTF, Maya,
// Houdini); z turns it into Blender's / 3ds Max's, (x, y, z) -> (x, -z, y),
// what Blender's glTF importer does to a mesh's vertices, so the Mesh Cache
// modifier needs no axis settings.
enum class UpAxis { y, z };

// One point cache per object (SourcePrimitive::object) of the character: a
// DCC tool's Mesh Cache / deformer takes exactly one object's vertices, in
// the object's order (its primitives' file vertices, concatenated). Points
// are in the file's mesh frame (for a skinned glTF mesh: its object frame).
struct ObjectPointCache {
  std::string object;
  PointCache cache;
};
std::vector<ObjectPointCache> object_point_caches(const Character& ch, const BakedFrames& frames, UpAxis up,
                                                  float start_frame);
// Where write_object_point_caches puts them: `path` itself for one object,
// else <path without .pc2>_<object>.pc2 (characters outside [A-Za-z0-9_.-]
// become '_'; a clash gets the object's index appended).
std::vector<std::string> object_point_cache_paths(const std::string& path, const std::vector<ObjectPointCache>& caches);
// Writes all of them or none (earlier files are removed when one fails);
// returns the paths.
std::vector<std::string> write_object_point_caches(const std::string& path, const std::vector<ObjectPointCache>& caches);

}  // namespace gatcore::character
