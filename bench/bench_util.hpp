#pragma once
// Shared pieces of gatbench: synthetic character-like meshes, random tensors,
// and the counters every benchmark reports. Header-only so that any new
// bench/*.cpp (the CMake glob picks it up) can include it.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatbench {

// ---- meshes -------------------------------------------------------------------
//
// A character mesh is a handful of separate parts (body, clothes, hair, eyes)
// of regular-ish triangulated surface with boundaries and seams, numbered part
// by part. We model that as patches of kPatchCols x kPatchRows vertices, each
// a grid whose quads are split along one diagonal: interior vertices have 6
// neighbours, boundary ones fewer, which gives an average degree of ~6.74
// including the self-loop (real skinned characters: 6.5 - 7).
inline constexpr int kPatchCols = 25;
inline constexpr int kPatchRows = 40;

// Triangles of a mesh with exactly `nodes` vertices: whole patches, then one
// partial patch whose last row may be short (quads are emitted only where all
// four corners exist).
inline std::vector<std::int32_t> mesh_triangles(std::int64_t nodes) {
  std::vector<std::int32_t> tris;
  tris.reserve(static_cast<std::size_t>(nodes) * 6);
  const std::int64_t per_patch = std::int64_t(kPatchCols) * kPatchRows;
  for (std::int64_t base = 0; base < nodes; base += per_patch) {
    const std::int64_t count = std::min(per_patch, nodes - base);
    auto exists = [&](std::int64_t r, std::int64_t c) { return r * kPatchCols + c < count; };
    for (std::int64_t r = 0; r + 1 < kPatchRows; ++r)
      for (std::int64_t c = 0; c + 1 < kPatchCols; ++c) {
        if (!exists(r + 1, c + 1)) continue;
        const auto a = static_cast<std::int32_t>(base + r * kPatchCols + c);
        const std::int32_t b = a + 1, d = a + kPatchCols, e = d + 1;
        tris.insert(tris.end(), {a, b, e, a, e, d});
      }
  }
  return tris;
}

// Mesh graph (symmetric, with self-loops) of `nodes` vertices.
inline gatcore::CsrGraph mesh_graph(std::int64_t nodes) {
  const std::vector<std::int32_t> tris = mesh_triangles(nodes);
  return gatcore::graph_from_triangles(nodes, tris);
}

// The k nearest vertices of every vertex by hop distance (itself first, then
// breadth-first in index order): a stand-in for NeuroSkinning's geodesic
// neighbourhoods used by neighbour_mean.
inline gatcore::CsrGraph hop_neighbourhoods(const gatcore::CsrGraph& g, int k) {
  const std::int64_t n = g.num_nodes;
  std::vector<std::vector<std::int32_t>> lists(static_cast<std::size_t>(n));
  std::vector<std::int32_t> queue;
  std::vector<std::int64_t> mark(static_cast<std::size_t>(n), -1);
  for (std::int64_t s = 0; s < n; ++s) {
    queue.assign(1, static_cast<std::int32_t>(s));
    mark[s] = s;
    for (std::size_t q = 0; q < queue.size() && static_cast<int>(queue.size()) < k; ++q) {
      const std::int32_t v = queue[q];
      for (std::int64_t e = g.indptr[v]; e < g.indptr[v + 1] && static_cast<int>(queue.size()) < k; ++e) {
        const std::int32_t u = g.indices[e];
        if (mark[u] != s) {
          mark[u] = s;
          queue.push_back(u);
        }
      }
    }
    lists[s] = queue;
  }
  return gatcore::graph_from_neighbour_lists(n, lists);
}

// Builds a value once per key and keeps it for the whole run: Google Benchmark
// calls a benchmark function several times while it sizes the iteration count,
// and 100k-node inputs are too costly to rebuild each time.
template <class T, class Key, class Make>
const T& cached(Key key, Make&& make) {
  static std::mutex mu;
  static std::map<Key, std::unique_ptr<T>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, std::make_unique<T>(make())).first;
  return *it->second;
}

// ---- tensors ----------------------------------------------------------------------
// Uniform values in [lo, hi), deterministic for a given seed.
inline gatcore::Tensor random_tensor(std::int64_t rows, std::int64_t cols, std::uint32_t seed, float lo = -1.0f,
                                     float hi = 1.0f) {
  gatcore::Tensor t = gatcore::Tensor::empty(rows, cols);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> dist(lo, hi);
  for (std::int64_t r = 0; r < rows; ++r) {
    float* p = t.row(r);
    for (std::int64_t c = 0; c < cols; ++c) p[c] = dist(rng);
  }
  return t;
}

// A valid attention tensor [E, H]: every row of the graph sums to 1 per head.
inline gatcore::Tensor uniform_attention(const gatcore::CsrGraph& g, int heads) {
  gatcore::Tensor a = gatcore::Tensor::empty(g.num_edges(), heads);
  for (std::int64_t i = 0; i < g.num_nodes; ++i) {
    const float w = 1.0f / static_cast<float>(std::max<std::int64_t>(1, g.degree(i)));
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (int k = 0; k < heads; ++k) a.at(e, k) = w;
  }
  return a;
}

// ---- reporting --------------------------------------------------------------------
// Per-iteration cost model of one kernel call: the bytes it must move at
// least (each input read once, each output written once, accumulated outputs
// read and written, index arrays read once) and its floating-point operations.
struct Cost {
  double bytes = 0;
  double flops = 0;
  std::int64_t items = 0;  // nodes (or rows) processed
};

inline constexpr double kF32 = 4.0;

// Bytes of walking a CSR by rows: indptr (int64) + indices (int32).
inline double csr_bytes(const gatcore::CsrGraph& g) {
  return 8.0 * static_cast<double>(g.num_nodes + 1) + 4.0 * static_cast<double>(g.num_edges());
}
// Bytes of walking the transpose: out_ptr + out_dst + out_edge.
inline double transpose_bytes(const gatcore::CsrGraph& g) {
  return 8.0 * static_cast<double>(g.num_nodes + 1) + 8.0 * static_cast<double>(g.num_edges());
}

// Reports "bytes" (B/s, shown as e.g. 12.3G/s = GB/s), "flops" (FLOP/s,
// 4.5G/s = GFLOP/s) and items (nodes) per second, all over wall time.
inline void report(benchmark::State& state, const Cost& c) {
  const double it = static_cast<double>(state.iterations());
  state.counters["bytes"] = benchmark::Counter(c.bytes * it, benchmark::Counter::kIsRate, benchmark::Counter::kIs1000);
  if (c.flops > 0)
    state.counters["flops"] =
        benchmark::Counter(c.flops * it, benchmark::Counter::kIsRate, benchmark::Counter::kIs1000);
  if (c.items > 0) state.SetItemsProcessed(state.iterations() * c.items);
}

// Runs `call` once outside the timing (warm-up, and a kernel that rejects its
// inputs turns into a skipped benchmark with the kernel's message instead of
// an aborted run), then the timed loop, then the counters.
template <class Call>
void run(benchmark::State& state, const Cost& cost, Call&& call) {
  try {
    call();
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  for (auto _ : state) call();
  report(state, cost);
}

}  // namespace gatbench
