// CSR graph builders, invariants and bad-input errors.
#include <catch2/catch.hpp>

#include <algorithm>
#include <limits>
#include <random>
#include <set>

#include "gatcore/graph.hpp"
#include "gatcore/ops.hpp"
#include "mesh_fixtures.hpp"

using namespace gatcore;

namespace {
std::set<std::pair<int, int>> edge_set(const CsrGraph& g) {
  std::set<std::pair<int, int>> s;
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) s.insert({g.indices[e], int(i)});  // src -> dst
  return s;
}
}  // namespace

TEST_CASE("mesh graph from triangles: deduplicated, undirected, self-loops, reverse permutation", "[graph]") {
  // Two triangles sharing edge 1-2, plus vertex 4 in no triangle.
  std::vector<std::int32_t> tris = {0, 1, 2, 2, 1, 3};
  CsrGraph g = graph_from_triangles(5, tris);
  REQUIRE_NOTHROW(g.validate());
  REQUIRE(g.symmetric);
  REQUIRE(g.self_loops);
  REQUIRE(g.num_nodes == 5);
  // 5 undirected edges -> 10 directed, + 5 self-loops.
  REQUIRE(g.num_edges() == 15);
  REQUIRE(g.degree(4) == 1);  // only its self-loop
  REQUIRE(g.degree(1) == 4);  // 0, 1, 2, 3
  // Reverse-edge permutation: out_edge of an edge i<-j is the edge j<-i.
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      const std::int32_t j = g.indices[e];
      const std::int32_t r = g.out_edge[e];
      REQUIRE(g.indices[r] == i);
      REQUIRE(g.indptr[j] <= r);
      REQUIRE(r < g.indptr[j + 1]);
    }
  // Sorted rows.
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    REQUIRE(std::is_sorted(g.indices.begin() + g.indptr[i], g.indices.begin() + g.indptr[i + 1]));
  REQUIRE(g.segment_ptr == std::vector<std::int64_t>{0, 5});
}

TEST_CASE("graph without self-loops leaves a vertex isolated", "[graph]") {
  GraphOptions o;
  o.self_loops = false;
  CsrGraph g = graph_from_triangles(4, std::vector<std::int32_t>{0, 1, 2}, o);
  REQUIRE_NOTHROW(g.validate());
  REQUIRE(g.degree(3) == 0);
  REQUIRE_FALSE(g.self_loops);
  // Degenerate triangle contributes only its distinct edge.
  CsrGraph d = graph_from_triangles(3, std::vector<std::int32_t>{0, 0, 1}, o);
  REQUIRE(d.num_edges() == 2);
}

TEST_CASE("edge lists: directed and symmetrised, duplicates removed", "[graph]") {
  std::vector<std::int32_t> src = {0, 0, 1, 2, 0}, dst = {1, 1, 2, 0, 1};
  GraphOptions directed;
  directed.self_loops = false;
  directed.symmetrize = false;
  CsrGraph g = graph_from_edges(3, src, dst, directed);
  REQUIRE_NOTHROW(g.validate());
  REQUIRE(g.num_edges() == 3);
  REQUIRE_FALSE(g.symmetric);
  REQUIRE(edge_set(g) == std::set<std::pair<int, int>>{{0, 1}, {1, 2}, {2, 0}});
  CsrGraph s = graph_from_edges(3, src, dst);
  REQUIRE(s.symmetric);
  REQUIRE(s.num_edges() == 6 + 3);
}

TEST_CASE("induced subgraph keeps internal edges and renumbers", "[graph]") {
  CsrGraph g = fixtures::grid_graph(5, 4);
  std::vector<std::int32_t> sel = {7, 6, 11, 12, 19};
  CsrGraph s = induced_subgraph(g, sel);
  REQUIRE_NOTHROW(s.validate());
  REQUIRE(s.num_nodes == 5);
  REQUIRE(s.self_loops);
  REQUIRE(s.symmetric);
  auto parent = edge_set(g);
  for (auto [a, b] : edge_set(s)) REQUIRE(parent.count({sel[a], sel[b]}) == 1);
  std::int64_t expected = 0;
  for (auto [a, b] : parent)
    if (std::count(sel.begin(), sel.end(), a) && std::count(sel.begin(), sel.end(), b)) ++expected;
  REQUIRE(s.num_edges() == expected);
  REQUIRE(s.degree(4) == 1);  // vertex 19 has no selected neighbour: self-loop only
}

TEST_CASE("block-diagonal batch", "[graph]") {
  CsrGraph a = fixtures::grid_graph(3, 3), b = fixtures::grid_graph(2, 2), c = graph_from_triangles(1, {});
  CsrGraph bt = batch_graphs({&a, &b, &c});
  REQUIRE_NOTHROW(bt.validate());
  REQUIRE(bt.num_nodes == 9 + 4 + 1);
  REQUIRE(bt.num_edges() == a.num_edges() + b.num_edges() + c.num_edges());
  REQUIRE(bt.segment_ptr == std::vector<std::int64_t>{0, 9, 13, 14});
  REQUIRE(bt.symmetric);
  for (std::int64_t i = 9; i < 13; ++i)
    for (std::int64_t e = bt.indptr[i]; e < bt.indptr[i + 1]; ++e) {
      REQUIRE(bt.indices[e] >= 9);
      REQUIRE(bt.indices[e] < 13);
    }
  // Batching a batch keeps the segments flat.
  CsrGraph bb = batch_graphs({&bt, &a});
  REQUIRE(bb.segment_ptr == std::vector<std::int64_t>{0, 9, 13, 14, 23});
  REQUIRE_NOTHROW(bb.validate());
}

TEST_CASE("balanced row ranges cover all rows and balance edges", "[graph]") {
  // Row 0 is very heavy.
  std::vector<std::vector<std::int32_t>> nb(100);
  for (int j = 0; j < 100; ++j) nb[0].push_back(j);
  for (int i = 1; i < 100; ++i) nb[i] = {std::int32_t(i)};
  CsrGraph g = graph_from_neighbour_lists(100, nb);
  for (int nt : {1, 2, 3, 8}) {
    std::int64_t prev = 0;
    for (int t = 0; t < nt; ++t) {
      RowRange r = balanced_rows(g.indptr, t, nt);
      REQUIRE(r.begin == prev);
      REQUIRE(r.end >= r.begin);
      prev = r.end;
    }
    REQUIRE(prev == 100);
  }
  // Each range costs (edges + rows) about total/nt, off by at most one row.
  const std::int64_t total = g.num_edges() + g.num_nodes, max_row = g.max_degree() + 1;
  for (int nt : {2, 3, 8})
    for (int t = 0; t < nt; ++t) {
      RowRange r = balanced_rows(g.indptr, t, nt);
      const std::int64_t cost = g.indptr[r.end] - g.indptr[r.begin] + (r.end - r.begin);
      REQUIRE(cost <= total / nt + max_row);
    }
  REQUIRE(balanced_rows(g.indptr, 0, 2).end == 25);  // row 0 (101) + 24 light rows (2 each) ~ 299 / 2
}

TEST_CASE("invalid graph input throws naming the problem", "[graph][errors]") {
  REQUIRE_THROWS_WITH(graph_from_triangles(3, std::vector<std::int32_t>{0, 1, 3}),
                      Catch::Contains("vertex index 3 outside [0, 3)"));
  REQUIRE_THROWS_WITH(graph_from_triangles(3, std::vector<std::int32_t>{0, -1, 2}),
                      Catch::Contains("vertex index -1"));
  REQUIRE_THROWS_WITH(graph_from_triangles(3, std::vector<std::int32_t>{0, 1}),
                      Catch::Contains("not a multiple of 3"));
  REQUIRE_THROWS_WITH(graph_from_triangles(-2, {}), Catch::Contains("negative node count"));
  REQUIRE_THROWS_WITH(graph_from_edges(3, std::vector<std::int32_t>{0, 1}, std::vector<std::int32_t>{1}),
                      Catch::Contains("src has 2 entries but dst has 1"));
  REQUIRE_THROWS_WITH(graph_from_edges(3, std::vector<std::int32_t>{0}, std::vector<std::int32_t>{5}),
                      Catch::Contains("destination 5"));
  CsrGraph g = fixtures::grid_graph(3, 3);
  REQUIRE_THROWS_WITH(induced_subgraph(g, std::vector<std::int32_t>{1, 1}), Catch::Contains("selected twice"));
  REQUIRE_THROWS_WITH(induced_subgraph(g, std::vector<std::int32_t>{1, 9}), Catch::Contains("vertex 1 is 9"));
  REQUIRE_THROWS_WITH(graph_from_neighbour_lists(2, {{0}, {2}}), Catch::Contains("neighbour 2"));
  CsrGraph broken = g;
  broken.indices[3] = 42;
  REQUIRE_THROWS_WITH(broken.validate(), Catch::Contains("source 42"));
  broken = g;
  broken.indptr.pop_back();
  REQUIRE_THROWS_WITH(broken.validate(), Catch::Contains("indptr has"));

  // NaN features are rejected with row and column.
  Tensor x = Tensor::zeros(g.num_nodes, 4);
  x.at(5, 2) = std::numeric_limits<float>::quiet_NaN();
  REQUIRE_THROWS_WITH(check_node_features(g, x, "positions"), Catch::Contains("positions: non-finite value") &&
                                                                  Catch::Contains("row 5, column 2"));
  REQUIRE_THROWS_WITH(check_node_features(g, Tensor::zeros(3, 4)), Catch::Contains("3 rows for a graph of 9"));
}
