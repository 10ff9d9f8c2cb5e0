#pragma once
// A triangle mesh with sparse per-vertex skin weights.
#include <cstdint>
#include <vector>

namespace gatcore::character {

// Influences of every vertex in CSR form: vertex v is bound to
// joint[k] with weight[k] for k in [ptr[v], ptr[v+1]); weights of a vertex are
// positive and sum to 1 (renormalised on import); joints sorted per vertex.
struct SkinWeights {
  std::vector<std::int64_t> ptr{0};  // [num_vertices + 1]
  std::vector<std::int32_t> joint;   // [num_influences]
  std::vector<float> weight;         // [num_influences]

  std::int64_t num_vertices() const { return static_cast<std::int64_t>(ptr.size()) - 1; }
  std::int64_t max_influences() const;
  // Dense [num_vertices x num_joints] row-major weights.
  std::vector<float> dense(std::int32_t num_joints) const;
};

struct Mesh {
  std::vector<float> positions;        // [3 * num_vertices] bind-pose positions (x, y, z)
  std::vector<std::int32_t> triangles; // [3 * num_triangles] vertex ids
  SkinWeights weights;

  std::int64_t num_vertices() const { return static_cast<std::int64_t>(positions.size() / 3); }
  std::int64_t num_triangles() const { return static_cast<std::int64_t>(triangles.size() / 3); }
  // Throws InvalidArgument naming `what` and the first broken invariant
  // (sizes, out-of-range ids, non-finite values, weights not summing to 1).
  void validate(std::int32_t num_joints, const char* what = "mesh") const;
};

// Connected components of the mesh (through triangle edges): a label per
// vertex in [0, count), labelled in order of first vertex.
struct Components {
  std::vector<std::int32_t> label;
  std::int32_t count = 0;
};
Components connected_components(const Mesh& mesh);

}  // namespace gatcore::character
