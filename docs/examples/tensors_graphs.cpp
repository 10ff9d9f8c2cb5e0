// docs/library.md, "Tensors and graphs": a strided column view, and a mesh
// graph from triangles with its transpose. Built and run by the ctest
// docs_example_tensors_graphs; exits non-zero when a check fails.
#include <cstdio>
#include <vector>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

int main() {
  using namespace gatcore;
  // [rows, cols] row-major float32, 64-byte aligned.
  Tensor x = Tensor::from(2, 3, {1, 2, 3, 4, 5, 6});
  Tensor right = x.cols_slice(1, 3);  // a view: shares storage, ld stays 3
  right.fill_(0.0f);                  // writes through to x, bumps the version
  std::printf("x = [%g %g %g; %g %g %g], view ld %lld\n", x.at(0, 0), x.at(0, 1), x.at(0, 2), x.at(1, 0),
              x.at(1, 1), x.at(1, 2), static_cast<long long>(right.ld()));

  // Two triangles sharing an edge: 4 vertices, 5 undirected edges, + self-loops.
  std::vector<std::int32_t> triangles = {0, 1, 2, 2, 1, 3};
  CsrGraph g = graph_from_triangles(4, triangles);
  g.validate();
  std::printf("nodes %lld, edges %lld (with self-loops), degree of vertex 1: %lld\n",
              static_cast<long long>(g.num_nodes), static_cast<long long>(g.num_edges()),
              static_cast<long long>(g.degree(1)));
  // Rows are destinations; for a mesh graph the transpose is the reverse-edge permutation.
  bool ok = x.at(0, 0) == 1 && x.at(0, 1) == 0 && x.at(1, 2) == 0 && g.num_edges() == 2 * 5 + 4 &&
            g.degree(1) == 4 && g.symmetric && g.self_loops;
  return ok ? 0 : 1;
}
