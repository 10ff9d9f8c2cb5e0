#pragma once
// Compressed sparse rows by destination: row i lists the source nodes j of the
// edges j -> i (node i aggregates from them), column indices sorted.
//
// The transpose (edges grouped by source) is stored too, so every backward
// pass is a gather over rows of the transpose: no atomics, deterministic.
// For a symmetric graph (every mesh graph) out_ptr == indptr and out_edge is
// exactly the reverse-edge permutation: out_edge[e] is the id of edge j -> i
// for the edge e = i -> j.
#include <cstdint>
#include <span>
#include <vector>

namespace gatcore {

struct CsrGraph {
  std::int64_t num_nodes = 0;
  std::vector<std::int64_t> indptr;   // [num_nodes + 1]
  std::vector<std::int32_t> indices;  // [E] source node of each edge, sorted per row
  std::vector<std::int64_t> out_ptr;  // [num_nodes + 1] transpose row pointers
  std::vector<std::int32_t> out_dst;  // [E] destination of each edge leaving node j, sorted
  std::vector<std::int32_t> out_edge; // [E] edge id (position in `indices`) of that edge
  // Node offsets of the component graphs when this graph is a block-diagonal
  // batch; {0, num_nodes} for a single graph. Used by per-graph pooling.
  std::vector<std::int64_t> segment_ptr;
  bool self_loops = false;  // every node has the edge i -> i
  bool symmetric = false;   // j -> i exists iff i -> j exists

  std::int64_t num_edges() const { return static_cast<std::int64_t>(indices.size()); }
  std::int64_t num_segments() const { return static_cast<std::int64_t>(segment_ptr.size()) - 1; }
  std::int64_t degree(std::int64_t i) const { return indptr[i + 1] - indptr[i]; }
  std::int64_t max_degree() const;

  // Throws InvalidArgument naming the first broken invariant.
  void validate() const;
};

struct GraphOptions {
  bool self_loops = true;   // add i -> i for every node (GAT convention)
  bool symmetrize = true;   // for edge lists: add the reverse of every edge
};

// Mesh edges of a triangle list (3 vertex indices per triangle), deduplicated
// and undirected. Degenerate triangles contribute only their distinct edges;
// vertices in no triangle become isolated nodes (or self-loop-only nodes).
CsrGraph graph_from_triangles(std::int64_t num_vertices, std::span<const std::int32_t> triangles,
                              const GraphOptions& opt = {});
// Edges src[k] -> dst[k]; duplicates removed.
CsrGraph graph_from_edges(std::int64_t num_nodes, std::span<const std::int32_t> src,
                          std::span<const std::int32_t> dst, const GraphOptions& opt = {});
// Graph of arbitrary neighbour lists: row i = neighbours[i] (e.g. the k nearest
// vertices by geodesic distance). Not symmetrised, duplicates removed.
CsrGraph graph_from_neighbour_lists(std::int64_t num_nodes, const std::vector<std::vector<std::int32_t>>& neighbours);

// The subgraph induced by `vertices` (node k of the result is vertices[k]).
// Keeps every edge with both ends selected; self-loops are kept (and
// re-added if the parent had them). Throws on duplicates / out-of-range ids.
CsrGraph induced_subgraph(const CsrGraph& g, std::span<const std::int32_t> vertices);

// Block-diagonal batch: node ids of graph b are offset by the node count of
// graphs 0..b-1; segment_ptr records the offsets.
CsrGraph batch_graphs(const std::vector<const CsrGraph*>& graphs);

// Rows [begin, end) for thread t of nt so that each range holds about the
// same number of edges (+1 per row so empty rows still cost something).
struct RowRange {
  std::int64_t begin, end;
};
RowRange balanced_rows(std::span<const std::int64_t> ptr, int t, int nt);

}  // namespace gatcore
