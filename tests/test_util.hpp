#pragma once
// Generic test helpers: CSR graphs built directly from adjacency lists (so a
// test controls isolated nodes, self-loops, hubs, batches exactly), random
// graphs and tensors, strided (column-slice) views with guard columns, and
// comparisons.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace testutil {

using Adjacency = std::vector<std::vector<std::int32_t>>;

// Graph whose row i lists the sources j of the edges j -> i (adj[i]; sorted
// and deduplicated here). Fills the transpose, segment_ptr ({0, n} unless
// `segments` is given), and the self_loops / symmetric flags from the edges.
inline gatcore::CsrGraph graph_from_adjacency(Adjacency adj, std::vector<std::int64_t> segments = {}) {
  gatcore::CsrGraph g;
  const std::int64_t n = static_cast<std::int64_t>(adj.size());
  g.num_nodes = n;
  g.indptr.assign(n + 1, 0);
  for (std::int64_t i = 0; i < n; ++i) {
    auto& row = adj[i];
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
    g.indptr[i + 1] = g.indptr[i] + static_cast<std::int64_t>(row.size());
    g.indices.insert(g.indices.end(), row.begin(), row.end());
  }
  const std::int64_t E = g.num_edges();
  // Transpose: count per source, then fill in destination order (rows are
  // visited in increasing i, so each source's list comes out sorted).
  g.out_ptr.assign(n + 1, 0);
  for (std::int32_t j : g.indices) ++g.out_ptr[j + 1];
  for (std::int64_t j = 0; j < n; ++j) g.out_ptr[j + 1] += g.out_ptr[j];
  g.out_dst.assign(E, 0);
  g.out_edge.assign(E, 0);
  std::vector<std::int64_t> fill(g.out_ptr.begin(), g.out_ptr.end() - 1);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      const std::int64_t p = fill[g.indices[e]]++;
      g.out_dst[p] = static_cast<std::int32_t>(i);
      g.out_edge[p] = static_cast<std::int32_t>(e);
    }
  g.segment_ptr = segments.empty() ? std::vector<std::int64_t>{0, n} : std::move(segments);
  g.self_loops = true;
  for (std::int64_t i = 0; i < n && g.self_loops; ++i)
    g.self_loops = std::binary_search(adj[i].begin(), adj[i].end(), static_cast<std::int32_t>(i));
  g.symmetric = true;
  for (std::int64_t i = 0; i < n && g.symmetric; ++i)
    for (std::int32_t j : adj[i])
      if (!std::binary_search(adj[j].begin(), adj[j].end(), static_cast<std::int32_t>(i))) {
        g.symmetric = false;
        break;
      }
  return g;
}

// Adjacency of a graph (row i -> its sources).
inline Adjacency adjacency_of(const gatcore::CsrGraph& g) {
  Adjacency adj(g.num_nodes);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    adj[i].assign(g.indices.begin() + g.indptr[i], g.indices.begin() + g.indptr[i + 1]);
  return adj;
}

struct RandomGraphOptions {
  int min_degree = 0;
  int max_degree = 10;
  bool self_loops = true;     // every non-isolated node gets i -> i
  bool symmetric = false;     // add the reverse of every edge
  int isolated = 0;           // the last `isolated` nodes get no edges at all
};

// Random directed graph on n nodes: each non-isolated row draws a degree in
// [min_degree, max_degree] and that many random sources among the
// non-isolated nodes.
inline gatcore::CsrGraph random_graph(std::int64_t n, std::uint32_t seed, const RandomGraphOptions& o = {}) {
  std::mt19937 rng(seed);
  const std::int64_t live = n - o.isolated;
  Adjacency adj(n);
  if (live > 0) {
    std::uniform_int_distribution<int> deg(o.min_degree, o.max_degree);
    std::uniform_int_distribution<std::int32_t> node(0, static_cast<std::int32_t>(live - 1));
    for (std::int64_t i = 0; i < live; ++i) {
      const int d = deg(rng);
      for (int k = 0; k < d; ++k) adj[i].push_back(node(rng));
      if (o.self_loops) adj[i].push_back(static_cast<std::int32_t>(i));
    }
    if (o.symmetric) {
      Adjacency sym = adj;
      for (std::int64_t i = 0; i < live; ++i)
        for (std::int32_t j : adj[i]) sym[j].push_back(static_cast<std::int32_t>(i));
      adj = std::move(sym);
    }
  }
  return graph_from_adjacency(std::move(adj));
}

// Block-diagonal batch of graphs (node ids offset, segment_ptr filled).
inline gatcore::CsrGraph batch_of(const std::vector<gatcore::CsrGraph>& parts) {
  Adjacency adj;
  std::vector<std::int64_t> seg{0};
  for (const auto& g : parts) {
    const auto off = static_cast<std::int32_t>(adj.size());
    for (auto row : adjacency_of(g)) {
      for (auto& j : row) j += off;
      adj.push_back(std::move(row));
    }
    seg.push_back(static_cast<std::int64_t>(adj.size()));
  }
  return graph_from_adjacency(std::move(adj), std::move(seg));
}

// ---- tensors ------------------------------------------------------------------

inline constexpr float kGuard = 12345.0f;  // value of the guard columns of strided views

// A [rows, cols] tensor; when `strided`, a column slice of a wider buffer
// (2 guard columns left, 3 right, all guard entries kGuard).
inline gatcore::Tensor make_tensor(std::int64_t rows, std::int64_t cols, bool strided) {
  if (!strided) return gatcore::Tensor::zeros(rows, cols);
  gatcore::Tensor buf = gatcore::Tensor::full(rows, cols + 5, kGuard);
  gatcore::Tensor v = buf.cols_slice(2, 2 + cols);
  v.fill_(0.0f);
  return v;
}

inline void fill_uniform(const gatcore::Tensor& t, std::mt19937& rng, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c) t.at(r, c) = u(rng);
}

inline gatcore::Tensor random_tensor(std::int64_t rows, std::int64_t cols, std::mt19937& rng, float lo = -1.0f,
                                     float hi = 1.0f, bool strided = false) {
  gatcore::Tensor t = make_tensor(rows, cols, strided);
  fill_uniform(t, rng, lo, hi);
  return t;
}

// Copy with the same layout (strided stays strided, guards included).
inline gatcore::Tensor copy_like(const gatcore::Tensor& t, bool strided) {
  gatcore::Tensor c = make_tensor(t.rows(), t.cols(), strided);
  c.copy_from_(t);
  return c;
}

// True when the guard columns around a strided view are untouched.
inline bool guards_intact(const gatcore::Tensor& t) {
  if (t.ld() == t.cols()) return true;
  const float* base = t.data() - 2;
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.ld(); ++c)
      if ((c < 2 || c >= 2 + t.cols()) && base[r * t.ld() + c] != kGuard) return false;
  return true;
}

inline bool bitwise_equal(const gatcore::Tensor& a, const gatcore::Tensor& b) {
  if (!a.same_shape(b)) return false;
  for (std::int64_t r = 0; r < a.rows(); ++r)
    for (std::int64_t c = 0; c < a.cols(); ++c) {
      const float x = a.at(r, c), y = b.at(r, c);
      if (std::memcmp(&x, &y, sizeof x) != 0) return false;
    }
  return true;
}

inline bool all_finite(const gatcore::Tensor& t) {
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c)
      if (!std::isfinite(t.at(r, c))) return false;
  return true;
}

}  // namespace testutil
