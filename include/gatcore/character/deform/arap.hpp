#pragma once
// As-rigid-as-possible surface deformation (Sorkine & Alexa 2007) driven by
// the skinned skeleton: a second, expensive reference deformer for
// DenseGATs' targets (Delta Mush stays the default).
//
// Handles: vertices whose dominant skin weight is >= handle_weight (the rigid
// middle of each limb segment) are pinned to their LBS positions. Every other
// vertex (the blend regions around joints, where LBS collapses and twists)
// minimises the ARAP energy
//   E(x) = sum_i sum_{j in N(i)} w_ij || (x_i - x_j) - R_i (p_i - p_j) ||^2
// over the positions x and one rotation R_i per vertex (p: rest mesh, w_ij:
// rest cotangent weights), by alternating the local step (R_i from the SVD of
// the edge covariance) and the global step (a sparse solve with the
// rest-pose Laplacian of the free vertices, factorised once per character by
// arap_bind), starting from LBS. Each iteration lowers E (tested): the
// surface keeps its rest edge lengths and local volume where LBS loses them.
//
// Cotangent weights are clamped at zero (w_ij = max(cot, 0)), so obtuse
// triangles cannot make the system indefinite. A piece of the mesh connected
// through edges of positive weight (a component, or a vertex whose every
// edge is opposite obtuse or right angles only) with no handle gets its
// vertex of largest dominant weight as one (else its translation is free).
//
// Cost per frame: `iterations` x (one 3x3 SVD per vertex + three sparse
// back-substitutions); measured in docs/RESULTS.md and bench (tens of ms for
// a 5k-vertex character at 10 iterations on this project's 2-core machine).
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gatcore/character/rig/mesh.hpp"

namespace gatcore::character {

// ARAP parameters, recorded in datasets like Delta Mush's.
struct ArapParams {
  int iterations = 10;         // local/global iterations per frame (>= 1)
  float handle_weight = 0.95f; // dominant weight that pins a vertex to LBS, in (0, 1]
  bool operator==(const ArapParams&) const = default;
};

struct ArapFactor;  // the factorised free-vertex Laplacian (Eigen, private)

struct ArapBinding {
  ArapParams params;
  std::vector<float> rest;                // [3 n]
  std::vector<std::int64_t> adj_ptr;      // one-ring (triangle edges), CSR
  std::vector<std::int32_t> adj;
  std::vector<double> weight;             // cotangent weight per adjacency entry (symmetric)
  std::vector<std::uint8_t> is_handle;    // [n]
  std::vector<std::int32_t> free_index;   // [n]: row in the solve, -1 for handles
  std::shared_ptr<const ArapFactor> factor;
  std::int64_t num_vertices() const { return static_cast<std::int64_t>(is_handle.size()); }
  std::int64_t num_handles() const;
};

// Builds the cotangent weights, picks the handles and factorises the free
// vertices' Laplacian. Throws InvalidArgument for bad parameters or meshes
// (mesh.validate's checks on the triangles and weights).
ArapBinding arap_bind(const Mesh& mesh, const ArapParams& params = {});
// Handles from an explicit mask instead of the skin weights (tests, users
// with their own pins); components without a handle still get one.
ArapBinding arap_bind(std::span<const float> rest, std::span<const std::int32_t> triangles,
                      std::vector<std::uint8_t> handles, const ArapParams& params = {});

// E(x) with the rotations that minimise it for this x (the local step).
double arap_energy(const ArapBinding& b, std::span<const float> x);

// `iterations` local/global steps from `initial` (typically the LBS
// positions); handles keep their `initial` positions. `energies`, if given,
// receives E after each iteration (evaluated with the local step's rotations
// of the next iteration, i.e. arap_energy of each iterate).
std::vector<float> arap_apply(const ArapBinding& b, std::span<const float> initial,
                              std::vector<double>* energies = nullptr);

}  // namespace gatcore::character
