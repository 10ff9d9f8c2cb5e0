#include "gatcore/graph.hpp"

#include <algorithm>
#include <numeric>

#include "gatcore/error.hpp"

namespace gatcore {

namespace {

constexpr std::int64_t kMaxIndex = 0x7fffffff;

// Builds the CSR (rows = destination) and its transpose from (dst, src) pairs
// that are already sorted by (dst, src) and deduplicated.
CsrGraph build_from_sorted_pairs(std::int64_t n, const std::vector<std::pair<std::int32_t, std::int32_t>>& pairs,
                                 bool self_loops) {
  CsrGraph g;
  g.num_nodes = n;
  const std::int64_t E = static_cast<std::int64_t>(pairs.size());
  GATCORE_CHECK(E <= kMaxIndex, "graph: ", E, " edges exceed the int32 edge-id range");
  g.indptr.assign(n + 1, 0);
  g.indices.resize(E);
  for (std::int64_t e = 0; e < E; ++e) {
    ++g.indptr[pairs[e].first + 1];
    g.indices[e] = pairs[e].second;
  }
  for (std::int64_t i = 0; i < n; ++i) g.indptr[i + 1] += g.indptr[i];

  // Transpose by counting sort on the source; scanning edges in id order keeps
  // each source's list sorted by destination.
  g.out_ptr.assign(n + 1, 0);
  for (std::int64_t e = 0; e < E; ++e) ++g.out_ptr[g.indices[e] + 1];
  for (std::int64_t i = 0; i < n; ++i) g.out_ptr[i + 1] += g.out_ptr[i];
  g.out_dst.resize(E);
  g.out_edge.resize(E);
  std::vector<std::int64_t> fill(g.out_ptr.begin(), g.out_ptr.end() - 1);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      std::int64_t p = fill[g.indices[e]]++;
      g.out_dst[p] = static_cast<std::int32_t>(i);
      g.out_edge[p] = static_cast<std::int32_t>(e);
    }

  g.self_loops = self_loops;
  g.symmetric = g.out_ptr == g.indptr && g.out_dst == g.indices;
  g.segment_ptr = {0, n};
  return g;
}

void check_node_count(std::int64_t n, const char* fn) {
  GATCORE_CHECK(n >= 0, fn, ": negative node count ", n);
  GATCORE_CHECK(n <= kMaxIndex, fn, ": node count ", n, " exceeds the int32 index range");
}

void sort_unique(std::vector<std::pair<std::int32_t, std::int32_t>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
}

void add_self_loops(std::int64_t n, std::vector<std::pair<std::int32_t, std::int32_t>>& pairs) {
  for (std::int64_t i = 0; i < n; ++i)
    pairs.emplace_back(static_cast<std::int32_t>(i), static_cast<std::int32_t>(i));
}

}  // namespace

std::int64_t CsrGraph::max_degree() const {
  std::int64_t m = 0;
  for (std::int64_t i = 0; i < num_nodes; ++i) m = std::max(m, degree(i));
  return m;
}

void CsrGraph::validate() const {
  const std::int64_t n = num_nodes;
  GATCORE_CHECK(n >= 0, "CsrGraph: negative num_nodes ", n);
  GATCORE_CHECK(static_cast<std::int64_t>(indptr.size()) == n + 1, "CsrGraph: indptr has ", indptr.size(),
                " entries, expected num_nodes + 1 = ", n + 1);
  GATCORE_CHECK(indptr[0] == 0, "CsrGraph: indptr[0] = ", indptr[0], ", expected 0");
  GATCORE_CHECK(indptr[n] == num_edges(), "CsrGraph: indptr[num_nodes] = ", indptr[n], " but indices has ",
                num_edges(), " entries");
  for (std::int64_t i = 0; i < n; ++i) {
    GATCORE_CHECK(indptr[i] <= indptr[i + 1], "CsrGraph: indptr decreases at row ", i);
    for (std::int64_t e = indptr[i]; e < indptr[i + 1]; ++e) {
      const std::int32_t j = indices[e];
      GATCORE_CHECK(j >= 0 && j < n, "CsrGraph: edge ", e, " of row ", i, " has source ", j,
                    " outside [0, ", n, ")");
      GATCORE_CHECK(e == indptr[i] || indices[e - 1] < j, "CsrGraph: row ", i,
                    " column indices not strictly increasing at edge ", e);
    }
    if (self_loops)
      GATCORE_CHECK(std::binary_search(indices.begin() + indptr[i], indices.begin() + indptr[i + 1],
                                       static_cast<std::int32_t>(i)),
                    "CsrGraph: self_loops is set but node ", i, " has no self-loop");
  }
  const std::int64_t E = num_edges();
  GATCORE_CHECK(static_cast<std::int64_t>(out_ptr.size()) == n + 1 &&
                    static_cast<std::int64_t>(out_dst.size()) == E &&
                    static_cast<std::int64_t>(out_edge.size()) == E,
                "CsrGraph: transpose arrays have the wrong size (out_ptr ", out_ptr.size(), ", out_dst ",
                out_dst.size(), ", out_edge ", out_edge.size(), ")");
  std::vector<char> seen(E, 0);
  for (std::int64_t j = 0; j < n; ++j)
    for (std::int64_t p = out_ptr[j]; p < out_ptr[j + 1]; ++p) {
      const std::int64_t e = out_edge[p];
      GATCORE_CHECK(e >= 0 && e < E && !seen[e], "CsrGraph: out_edge[", p, "] = ", e,
                    " is out of range or repeated");
      seen[e] = 1;
      const std::int32_t i = out_dst[p];
      GATCORE_CHECK(i >= 0 && i < n && indptr[i] <= e && e < indptr[i + 1] && indices[e] == j,
                    "CsrGraph: transpose entry ", p, " (", j, " -> ", i, ", edge ", e,
                    ") does not match the CSR");
    }
  GATCORE_CHECK(segment_ptr.size() >= 2 && segment_ptr.front() == 0 && segment_ptr.back() == n,
                "CsrGraph: segment_ptr must start at 0 and end at num_nodes = ", n);
  for (std::size_t s = 1; s < segment_ptr.size(); ++s)
    GATCORE_CHECK(segment_ptr[s - 1] <= segment_ptr[s], "CsrGraph: segment_ptr decreases at ", s);
}

CsrGraph graph_from_triangles(std::int64_t num_vertices, std::span<const std::int32_t> triangles,
                              const GraphOptions& opt) {
  check_node_count(num_vertices, "graph_from_triangles");
  GATCORE_CHECK(triangles.size() % 3 == 0, "graph_from_triangles: triangle index list has ", triangles.size(),
                " entries, not a multiple of 3");
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  pairs.reserve(triangles.size() * 2 + (opt.self_loops ? num_vertices : 0));
  for (std::size_t t = 0; t < triangles.size() / 3; ++t) {
    for (int c = 0; c < 3; ++c) {
      const std::int32_t v = triangles[3 * t + c];
      GATCORE_CHECK(v >= 0 && v < num_vertices, "graph_from_triangles: triangle ", t, " corner ", c,
                    " has vertex index ", v, " outside [0, ", num_vertices, ")");
    }
    for (int c = 0; c < 3; ++c) {
      const std::int32_t a = triangles[3 * t + c], b = triangles[3 * t + (c + 1) % 3];
      if (a == b) continue;  // degenerate triangle: skip the collapsed edge
      pairs.emplace_back(a, b);
      pairs.emplace_back(b, a);
    }
  }
  if (opt.self_loops) add_self_loops(num_vertices, pairs);
  sort_unique(pairs);
  return build_from_sorted_pairs(num_vertices, pairs, opt.self_loops);
}

CsrGraph graph_from_edges(std::int64_t num_nodes, std::span<const std::int32_t> src,
                          std::span<const std::int32_t> dst, const GraphOptions& opt) {
  check_node_count(num_nodes, "graph_from_edges");
  GATCORE_CHECK(src.size() == dst.size(), "graph_from_edges: src has ", src.size(), " entries but dst has ",
                dst.size());
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  pairs.reserve(src.size() * (opt.symmetrize ? 2 : 1) + (opt.self_loops ? num_nodes : 0));
  for (std::size_t k = 0; k < src.size(); ++k) {
    GATCORE_CHECK(src[k] >= 0 && src[k] < num_nodes, "graph_from_edges: edge ", k, " has source ", src[k],
                  " outside [0, ", num_nodes, ")");
    GATCORE_CHECK(dst[k] >= 0 && dst[k] < num_nodes, "graph_from_edges: edge ", k, " has destination ", dst[k],
                  " outside [0, ", num_nodes, ")");
    pairs.emplace_back(dst[k], src[k]);
    if (opt.symmetrize) pairs.emplace_back(src[k], dst[k]);
  }
  if (opt.self_loops) add_self_loops(num_nodes, pairs);
  sort_unique(pairs);
  CsrGraph g = build_from_sorted_pairs(num_nodes, pairs, opt.self_loops);
  return g;
}

CsrGraph graph_from_neighbour_lists(std::int64_t num_nodes,
                                    const std::vector<std::vector<std::int32_t>>& neighbours) {
  check_node_count(num_nodes, "graph_from_neighbour_lists");
  GATCORE_CHECK(static_cast<std::int64_t>(neighbours.size()) == num_nodes, "graph_from_neighbour_lists: ",
                neighbours.size(), " neighbour lists for ", num_nodes, " nodes");
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  bool all_self = true;
  for (std::int64_t i = 0; i < num_nodes; ++i) {
    bool self = false;
    for (std::int32_t j : neighbours[i]) {
      GATCORE_CHECK(j >= 0 && j < num_nodes, "graph_from_neighbour_lists: node ", i, " lists neighbour ", j,
                    " outside [0, ", num_nodes, ")");
      pairs.emplace_back(static_cast<std::int32_t>(i), j);
      self |= j == i;
    }
    all_self &= self;
  }
  sort_unique(pairs);
  return build_from_sorted_pairs(num_nodes, pairs, all_self && num_nodes > 0);
}

CsrGraph induced_subgraph(const CsrGraph& g, std::span<const std::int32_t> vertices) {
  const std::int64_t m = static_cast<std::int64_t>(vertices.size());
  std::vector<std::int32_t> local(g.num_nodes, -1);
  for (std::int64_t k = 0; k < m; ++k) {
    const std::int32_t v = vertices[k];
    GATCORE_CHECK(v >= 0 && v < g.num_nodes, "induced_subgraph: vertex ", k, " is ", v, " outside [0, ",
                  g.num_nodes, ")");
    GATCORE_CHECK(local[v] < 0, "induced_subgraph: vertex ", v, " selected twice (positions ", local[v], " and ",
                  k, ")");
    local[v] = static_cast<std::int32_t>(k);
  }
  std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
  for (std::int64_t k = 0; k < m; ++k) {
    const std::int32_t v = vertices[k];
    for (std::int64_t e = g.indptr[v]; e < g.indptr[v + 1]; ++e) {
      const std::int32_t u = local[g.indices[e]];
      if (u >= 0) pairs.emplace_back(static_cast<std::int32_t>(k), u);
    }
  }
  if (g.self_loops) add_self_loops(m, pairs);
  sort_unique(pairs);
  return build_from_sorted_pairs(m, pairs, g.self_loops);
}

CsrGraph batch_graphs(const std::vector<const CsrGraph*>& graphs) {
  CsrGraph b;
  std::int64_t n = 0, E = 0;
  bool self = !graphs.empty(), sym = true;
  for (std::size_t k = 0; k < graphs.size(); ++k) {
    GATCORE_CHECK(graphs[k] != nullptr, "batch_graphs: graph ", k, " is null");
    n += graphs[k]->num_nodes;
    E += graphs[k]->num_edges();
    self &= graphs[k]->self_loops;
    sym &= graphs[k]->symmetric;
  }
  check_node_count(n, "batch_graphs");
  GATCORE_CHECK(E <= kMaxIndex, "batch_graphs: ", E, " edges exceed the int32 edge-id range");
  b.num_nodes = n;
  b.indptr.reserve(n + 1);
  b.out_ptr.reserve(n + 1);
  b.indices.reserve(E);
  b.out_dst.reserve(E);
  b.out_edge.reserve(E);
  b.indptr.push_back(0);
  b.out_ptr.push_back(0);
  b.segment_ptr.push_back(0);
  std::int64_t node0 = 0, edge0 = 0;
  for (const CsrGraph* g : graphs) {
    for (std::int64_t i = 1; i <= g->num_nodes; ++i) {
      b.indptr.push_back(edge0 + g->indptr[i]);
      b.out_ptr.push_back(edge0 + g->out_ptr[i]);
    }
    for (std::int64_t e = 0; e < g->num_edges(); ++e) {
      b.indices.push_back(static_cast<std::int32_t>(g->indices[e] + node0));
      b.out_dst.push_back(static_cast<std::int32_t>(g->out_dst[e] + node0));
      b.out_edge.push_back(static_cast<std::int32_t>(g->out_edge[e] + edge0));
    }
    // A batch of batches stays flat: keep the component's own segments.
    const bool has_segments = g->segment_ptr.size() >= 2;
    for (std::size_t s = 1; s < g->segment_ptr.size(); ++s) b.segment_ptr.push_back(node0 + g->segment_ptr[s]);
    node0 += g->num_nodes;
    edge0 += g->num_edges();
    if (!has_segments) b.segment_ptr.push_back(node0);
  }
  if (graphs.empty()) b.segment_ptr.push_back(0);
  b.self_loops = self;
  b.symmetric = sym;
  return b;
}

RowRange balanced_rows(std::span<const std::int64_t> ptr, int t, int nt) {
  const std::int64_t n = static_cast<std::int64_t>(ptr.size()) - 1;
  if (n <= 0 || nt <= 1) return {t == 0 ? 0 : std::max<std::int64_t>(n, 0), std::max<std::int64_t>(n, 0)};
  // Cost of rows [0, i) is ptr[i] - ptr[0] + i; find the row where thread t's
  // share of the total starts by binary search (cost is monotone in i).
  const std::int64_t total = ptr[n] - ptr[0] + n;
  auto start = [&](int k) -> std::int64_t {
    if (k <= 0) return 0;
    if (k >= nt) return n;
    const std::int64_t target = total * k / nt;
    std::int64_t lo = 0, hi = n;
    while (lo < hi) {
      std::int64_t mid = (lo + hi) / 2;
      if (ptr[mid] - ptr[0] + mid < target) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  };
  return {start(t), start(t + 1)};
}

}  // namespace gatcore
