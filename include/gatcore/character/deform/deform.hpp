#pragma once
// Mesh deformation: linear blend skinning, dual-quaternion skinning (Kavan
// et al. 2007), area-weighted vertex normals, and Delta Mush (Mancewicz et
// al. 2014) on top of LBS — the reference nonlinear deformer that produces
// DenseGATs' targets. All OpenMP-parallel over vertices; positions are
// [3 * num_vertices] floats.
#include <cstdint>
#include <span>
#include <vector>

#include "gatcore/character/rig/mesh.hpp"
#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character {

// v' = sum_j w_j M_j v  with M_j = skinning_matrices(...)[j].
std::vector<float> linear_blend_skinning(const Mesh& mesh, std::span<const Mat4> skinning);
// The same into caller memory ([3 n]; no allocation: the runtime's per-frame path).
void linear_blend_skinning(const Mesh& mesh, std::span<const Mat4> skinning, std::span<float> out);
// Vectors attached to the vertices ([3 * n]) carried by LBS's blended linear
// parts: d' = (sum_j w_j A_j) d, A_j the 3x3 of M_j (no translation).
std::vector<float> skin_vectors(const Mesh& mesh, std::span<const Mat4> skinning, std::span<const float> vectors);
void skin_vectors(const Mesh& mesh, std::span<const Mat4> skinning, std::span<const float> vectors, std::span<float> out);
// Blends the rigid parts of M_j as dual quaternions (antipodality resolved
// against the vertex's strongest influence). Scale in M_j is ignored.
std::vector<float> dual_quaternion_skinning(const Mesh& mesh, std::span<const Mat4> skinning);

// Area-weighted vertex normals (sum of unnormalised face normals), unit
// length; (0, 0, 0) for vertices in no (non-degenerate) triangle.
std::vector<float> vertex_normals(std::span<const float> positions, std::span<const std::int32_t> triangles);
// The same into `out` [3 n], accumulating in `scratch` [3 n] (no allocation).
void vertex_normals(std::span<const float> positions, std::span<const std::int32_t> triangles, std::span<float> out,
                    std::span<double> scratch);

// Delta Mush parameters, recorded in datasets.
struct DeltaMushParams {
  int iterations = 10;  // Laplacian smoothing steps
  float step = 0.5f;    // lambda: x <- x + step * (mean(neighbours) - x)
};

// Rest-pose data of Delta Mush: the deltas between the rest mesh and its
// smoothed version, expressed in per-vertex frames of the smoothed mesh.
struct DeltaMush {
  DeltaMushParams params;
  std::vector<std::int64_t> adj_ptr;   // one-ring (triangle edges), CSR
  std::vector<std::int32_t> adj;
  std::vector<std::int32_t> triangles;  // for the smoothed meshes' normals
  std::vector<float> deltas;           // [3 * n] in the smoothed-frame basis
};

// `iterations` steps of x <- x + step * (mean of the one-ring - x) over dm's
// adjacency (vertices without neighbours stay put).
std::vector<float> laplacian_smooth(const DeltaMush& dm, std::span<const float> x, int iterations, float step);
// The same into `out` [3 n] with `scratch` [3 n] (no allocation); `x` may alias `out`.
void laplacian_smooth(const DeltaMush& dm, std::span<const float> x, int iterations, float step, std::span<float> out,
                      std::span<float> scratch);

DeltaMush delta_mush_bind(const Mesh& mesh, const DeltaMushParams& params = {});
// Smooths `posed` (typically LBS of a pose) and adds the rest deltas back in
// the smoothed posed frames.
std::vector<float> delta_mush_apply(const DeltaMush& dm, std::span<const float> posed);

}  // namespace gatcore::character
