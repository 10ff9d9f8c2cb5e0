// Geodesic k-nearest vertices: Dijkstra on the mesh graph from every vertex,
// stopped after k vertices are settled. A kernel over sources, so OpenMP
// (the runtime's weight prediction calls it and links no oneTBB); serial
// inside a dataset pipeline task (SerialRegion), never nested in oneTBB.
#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

#include "gatcore/character/features/features.hpp"
#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::vector<std::vector<std::int32_t>> geodesic_knn_lists(std::span<const float> positions,
                                                          std::span<const std::int32_t> triangles, int k) {
  GATCORE_CHECK(k >= 1, "geodesic_knn: k must be >= 1, got ", k);
  GATCORE_CHECK(positions.size() % 3 == 0 && triangles.size() % 3 == 0,
                "geodesic_knn: positions and triangles must be multiples of 3");
  const std::int64_t n = static_cast<std::int64_t>(positions.size() / 3);
  GraphOptions opt;
  opt.self_loops = false;
  const CsrGraph g = graph_from_triangles(n, triangles, opt);
  std::vector<float> len(g.indices.size());
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      const std::int64_t j = g.indices[e];
      double d2 = 0.0;
      for (int c = 0; c < 3; ++c) d2 += (double)(positions[3 * i + c] - positions[3 * j + c]) * (positions[3 * i + c] - positions[3 * j + c]);
      len[e] = static_cast<float>(std::sqrt(d2));
    }
  std::vector<std::vector<std::int32_t>> out(static_cast<std::size_t>(n));
  // Each source's list depends on nothing but the graph, so any schedule
  // gives the same lists; the scratch arrays are per thread.
#pragma omp parallel if (!SerialRegion::active())
  {
    std::vector<float> dist(static_cast<std::size_t>(n), std::numeric_limits<float>::infinity());
    std::vector<char> settled(static_cast<std::size_t>(n), 0);
    std::vector<std::int32_t> touched;
    using Item = std::pair<float, std::int32_t>;
#pragma omp for schedule(dynamic, 64)
    for (std::int64_t src = 0; src < n; ++src) {
      std::priority_queue<Item, std::vector<Item>, std::greater<Item>> pq;
      auto& res = out[static_cast<std::size_t>(src)];
      res.reserve(static_cast<std::size_t>(k));
      dist[static_cast<std::size_t>(src)] = 0.0f;
      touched.push_back(static_cast<std::int32_t>(src));
      pq.push({0.0f, static_cast<std::int32_t>(src)});
      while (!pq.empty() && static_cast<int>(res.size()) < k) {
        const auto [d, u] = pq.top();
        pq.pop();
        if (settled[u]) continue;
        settled[u] = 1;
        res.push_back(u);
        for (std::int64_t e = g.indptr[u]; e < g.indptr[u + 1]; ++e) {
          const std::int32_t w = g.indices[e];
          const float nd = d + len[e];
          if (!settled[w] && nd < dist[w]) {
            if (dist[w] == std::numeric_limits<float>::infinity()) touched.push_back(w);
            dist[w] = nd;
            pq.push({nd, w});
          }
        }
      }
      for (std::int32_t t : touched) {
        dist[t] = std::numeric_limits<float>::infinity();
        settled[t] = 0;
      }
      touched.clear();
    }
  }
  return out;
}

CsrGraph geodesic_knn(std::span<const float> positions, std::span<const std::int32_t> triangles, int k) {
  const auto lists = geodesic_knn_lists(positions, triangles, k);
  return graph_from_neighbour_lists(static_cast<std::int64_t>(lists.size()), lists);
}

}  // namespace gatcore::character
