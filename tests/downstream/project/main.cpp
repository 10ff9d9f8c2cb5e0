// Uses only the installed public headers: builds the graph of a 3x3-vertex
// triangulated grid and a tensor, and prints facts the test script checks.
#include <cstdint>
#include <iostream>
#include <vector>

#include <gatcore/error.hpp>
#include <gatcore/graph.hpp>
#include <gatcore/tensor.hpp>

int main() {
  // 3x3 vertices, 2x2 quads, each split along the (r,c)-(r+1,c+1) diagonal.
  std::vector<std::int32_t> tris;
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 2; ++c) {
      const std::int32_t v00 = r * 3 + c, v01 = v00 + 1, v10 = v00 + 3, v11 = v00 + 4;
      tris.insert(tris.end(), {v00, v01, v11, v00, v11, v10});
    }
  const gatcore::CsrGraph g = gatcore::graph_from_triangles(9, tris);
  g.validate();

  // Row of the centre vertex 4: itself and its six mesh neighbours.
  std::cout << "nodes=" << g.num_nodes << " edges=" << g.num_edges() << " max_degree=" << g.max_degree()
            << " symmetric=" << g.symmetric << " self_loops=" << g.self_loops << " row4=";
  for (std::int64_t e = g.indptr[4]; e < g.indptr[5]; ++e) std::cout << (e > g.indptr[4] ? "," : "") << g.indices[e];
  std::cout << "\n";

  const gatcore::Tensor t = gatcore::Tensor::from(2, 3, {1, 2, 3, 4, 5, 6});
  const gatcore::Tensor col = t.cols_slice(1, 3);
  float sum = 0;
  for (float v : col.to_vector()) sum += v;
  std::cout << "tensor=" << t.shape_str() << " slice=" << col.shape_str() << " slice_sum=" << sum << "\n";

  // Exceptions thrown inside the library reach the caller with their type.
  try {
    const std::vector<std::int32_t> bad = {0, 1, 9};
    (void)gatcore::graph_from_triangles(9, bad);
    std::cout << "error=none\n";
  } catch (const gatcore::InvalidArgument& e) {
    std::cout << "error=InvalidArgument\n";
  }
  return 0;
}
