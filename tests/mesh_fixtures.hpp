#pragma once
// Small deterministic meshes for tests: a triangulated grid, optionally with
// isolated vertices appended (no triangle touches them).
#include <cstdint>
#include <vector>

#include "gatcore/graph.hpp"

namespace fixtures {

inline std::vector<std::int32_t> grid_triangles(int w, int h) {
  std::vector<std::int32_t> t;
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const std::int32_t a = y * w + x, b = a + 1, c = a + w, d = c + 1;
      t.insert(t.end(), {a, b, d, a, d, c});
    }
  return t;
}

// w×h grid mesh graph with self-loops, plus `isolated` vertices with no edges
// at all (not even a self-loop) when `self_loops` is false for them: we build
// without self-loops and add them only to grid vertices.
inline gatcore::CsrGraph grid_graph(int w, int h, int isolated = 0, bool self_loops = true) {
  const std::int64_t n = std::int64_t(w) * h + isolated;
  auto tris = grid_triangles(w, h);
  if (!self_loops || isolated == 0) {
    gatcore::GraphOptions o;
    o.self_loops = self_loops;
    return gatcore::graph_from_triangles(n, tris, o);
  }
  // Self-loops on the grid only, so the isolated vertices stay truly isolated.
  std::vector<std::int32_t> src, dst;
  for (std::size_t k = 0; k < tris.size(); k += 3)
    for (int c = 0; c < 3; ++c) {
      src.push_back(tris[k + c]);
      dst.push_back(tris[k + (c + 1) % 3]);
    }
  for (std::int32_t i = 0; i < w * h; ++i) {
    src.push_back(i);
    dst.push_back(i);
  }
  gatcore::GraphOptions o;
  o.self_loops = false;
  o.symmetrize = true;
  return gatcore::graph_from_edges(n, src, dst, o);
}

}  // namespace fixtures
