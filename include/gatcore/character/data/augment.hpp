#pragma once
// Training-data augmentations for skin-weight models: each a function from a
// rigged character (welded mesh, skeleton, artists' weights) to a new one,
// deterministic from a seed, showing a model the rigs users bring (game-ready
// rigs with rigid parts, low-poly meshes, other naming conventions, twist and
// helper bones, other chain lengths, other orientations and units). Every
// result keeps the data consistent: weights positive and summing to 1 per
// vertex, at most `max_influences` per vertex, joint ids valid, parents before
// children, the rest and bind transforms consistent with the mesh. Where the
// geometry still defines them, the artists' boundaries (each vertex's dominant
// bone) are kept: only a split / merged bone's own vertices change it.
//
// A variant whose mesh or joints change is one mesh object with no clips:
// identity file-vertex map, one primitive, no file nodes (the source's
// animations and exports do not fit an edited skeleton or mesh).
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

enum class AugmentKind : std::uint8_t {
  rigid,     // pieces dominated by one bone (and some small seeded ones) bound wholly to it
  decimate,  // edge-collapse decimation (meshoptimizer): surviving vertices keep their weights
  remesh,    // low-poly vertex-cluster remesh per piece; weights from the nearest source surface point
  rename,    // body joints renamed to another rig convention's names
  split,     // one bone cut in two along its segment (the distal half takes its children)
  merge,     // one child merged into its parent (weights summed)
  helpers,   // extra IK / pole / control / socket bones with no weights
  twist,     // upper arms, forearms, thighs get a twist bone (distal half of their weights)
  chains,    // one more or one fewer bone in the spine, neck or a finger
  rotate,    // rotated about the up axis (with a small tilt)
  scale,     // uniformly scaled (0.01 .. 100, log-uniform)
  z_up,      // the whole character turned Z-up
};

// "rigid", "decimate", "remesh", "rename", "split", "merge", "helpers",
// "twist", "chains", "rotate", "scale", "z-up".
const char* augment_kind_name(AugmentKind k);
const std::vector<AugmentKind>& all_augment_kinds();
// Comma- (or '+'-) separated names; "all" is every kind. Throws
// InvalidArgument naming `what`, the unknown name and the known ones; an empty
// list or a name given twice is an error too.
std::vector<AugmentKind> parse_augment_kinds(const std::string& list, const std::string& what);

struct AugmentOptions {
  int max_influences = 4;       // top-k of every result
  float rigid_share = 0.8f;     // a piece whose dominant bone holds this share of its weight becomes rigid
  float rigid_pick = 0.5f;      // probability that another piece (under rigid_max_piece of the vertices) does
  float rigid_max_piece = 0.2f;
  float decimate_min = 0.15f, decimate_max = 0.5f;  // kept share of triangles
  float remesh_cells_min = 24, remesh_cells_max = 64;  // grid cells along the bounding box's longest side
  float ramp = 0.15f;           // split / twist: width of the weight ramp, in bone lengths
};

// --- one augmentation at a time (the building blocks; deterministic) ---

// The dominant bone's share per connected piece; pieces at or above
// rigid_share, and small pieces picked with probability rigid_pick, get
// exactly one influence: their dominant bone.
Character rigid_parts(const Character& c, std::uint32_t seed, const AugmentOptions& o = {});
// Keeps about `keep` of the triangles (edge collapse, borders locked);
// unreferenced vertices dropped, the others unchanged (position, weights).
Character decimate(const Character& c, float keep, const AugmentOptions& o = {});
// Vertex clustering on a grid of `cells` along the longest side, per
// connected piece (pieces never fuse); each cluster's vertex at its members'
// centroid, its weights interpolated at the nearest point of the source
// triangles around the cluster (barycentric, then top-k); a piece that
// falls within one or two cells vanishes. `source_triangle`
// (when given) receives that triangle per new vertex.
Character remesh(const Character& c, float cells, const AugmentOptions& o = {},
                 std::vector<std::int32_t>* source_triangle = nullptr);
// Cuts `bone` at fraction `at` of its segment (head to its only child's head,
// in bind space): a new joint `name` at index bone + 1 (later joints shift by
// one). take_children: the new joint becomes the parent of bone's children
// (a split); otherwise it is a leaf (a twist bone). Vertex weights on `bone`
// are shared by position along the segment (a ramp `ramp` bone lengths wide
// around `at`): the two parts sum to the original. Throws InvalidArgument
// when the bone has no single child at a distance.
Character split_bone(const Character& c, std::int32_t bone, float at, const std::string& name, bool take_children,
                     const AugmentOptions& o = {});
// Removes `child` (not a root): its weights go to its parent, its children
// hang from the parent with the same rest transforms.
Character merge_bone(const Character& c, std::int32_t child, const AugmentOptions& o = {});
// Renames the joints map_rig maps onto body parts to `convention`'s names
// ("mixamo", "unreal", "rigify"); the others keep theirs (made unique).
Character rename_bones(const Character& c, const std::string& convention);
const std::vector<std::string>& rename_conventions();
// Adds IK targets, poles, a control root and a socket (leaf joints at the end,
// no weights).
Character add_helper_bones(const Character& c, std::uint32_t seed);
// The skeleton and mesh moved together by `m` (a rotation times a uniform
// scale, then a translation): bind positions, inverse binds and the roots'
// parents; weights unchanged.
Character transform_character(const Character& c, const Mat4& m);

// --- a variant: several kinds, each with seeded parameters ---

// Applies `kinds` in a fixed order (mesh, then skeleton, then placement;
// remesh and decimate together: remesh only);
// kinds that do not apply (no humanoid spine for `chains`, no bone to split)
// leave the character unchanged. Names the result after the source:
// "<source name without extension>~aug<seed>".
Character augment_character(const Character& c, const std::vector<AugmentKind>& kinds, std::uint32_t seed,
                            const AugmentOptions& o = {});

// Dataset entries of variants: "augment:KIND+KIND:SEED:SOURCE" where SOURCE
// is the source's own entry (a file or a procedural spec).
struct AugmentEntry {
  std::vector<AugmentKind> kinds;
  std::uint32_t seed = 0;
  std::string source;
};
bool is_augment_entry(const std::string& entry);
std::string augment_entry(const AugmentEntry& e);
// Throws InvalidArgument naming the entry for a malformed one.
AugmentEntry parse_augment_entry(const std::string& entry);

}  // namespace gatcore::character
