// Pooling kernels (segment max / broadcast, neighbour mean) against the
// double references: batches with empty segments, ties, a non-symmetric
// neighbour graph with empty neighbour sets, strided views, 1 vs 2 threads.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <set>
#include <vector>

#include "gatcore/graph.hpp"
#include "src/backends/cpu/pooling.hpp"
#include "reference/nn_reference.hpp"

using namespace gatcore;
using namespace gatcore::testutil;
using Catch::Matchers::Contains;
using ref::Mat;

namespace {

// An int32 [rows, cols] tensor, optionally a column slice of a wider one.
Tensor make_i32(std::int64_t rows, std::int64_t cols, bool strided) {
  if (!strided) return Tensor::zeros(rows, cols, DType::i32);
  return Tensor::zeros(rows, cols + 4, DType::i32).cols_slice(1, 1 + cols);
}

// k-nearest-style neighbour lists: node i gets 1 + (i % k) distinct random
// neighbours (possibly itself); nodes in `empty` get none. Not symmetric.
std::vector<std::vector<std::int32_t>> random_lists(Rng& rng, std::int64_t n, int k, std::set<std::int64_t> empty) {
  std::vector<std::vector<std::int32_t>> lists(n);
  std::uniform_int_distribution<std::int32_t> u(0, static_cast<std::int32_t>(n - 1));
  for (std::int64_t i = 0; i < n; ++i) {
    if (empty.count(i)) continue;
    std::set<std::int32_t> s;
    const std::size_t want = std::min<std::size_t>(1 + i % k, n);
    while (s.size() < want) s.insert(u(rng));
    lists[i].assign(s.begin(), s.end());
  }
  return lists;
}

}  // namespace

// ==== segment max ===================================================================

TEST_CASE("segment max: a batch with empty segments, strided views, forward and backward", "[pooling][segment_max]") {
  Rng rng(101);
  const std::vector<std::int64_t> seg = {0, 0, 5, 5, 17, 18, 18, 40};  // empty, 5, empty, 12, 1, empty, 22
  const std::int64_t n = 40, S = 7;
  for (std::int64_t C : {1, 16, 17, 33})
    for (int strided = 0; strided < 2; ++strided) {
      INFO("C " << C << " strided " << strided);
      Tensor x = random(rng, n, C, strided, -5, 5);
      Tensor out = make(S, C, !strided);
      Tensor arg = make_i32(S, C, strided);
      cpu::segment_max_forward(x, seg, out, arg);
      Mat want;
      std::vector<std::int32_t> want_arg;
      ref::segment_max(ref::to_mat(x), seg, want, want_arg);
      require_close(out, want, 0, 0, "segment max");
      REQUIRE(pad_intact(out));
      for (std::int64_t s = 0; s < S; ++s)
        for (std::int64_t c = 0; c < C; ++c) {
          INFO("segment " << s << " column " << c);
          REQUIRE(arg.at_i32(s, c) == want_arg[s * C + c]);
          if (seg[s] == seg[s + 1]) {
            REQUIRE(arg.at_i32(s, c) == -1);
            REQUIRE(out.at(s, c) == 0.0f);
          }
        }
      Tensor d_out = random(rng, S, C, !strided), d_x = random(rng, n, C, strided);
      Mat dxw = ref::to_mat(d_x);
      for (std::int64_t s = 0; s < S; ++s)
        for (std::int64_t c = 0; c < C; ++c)
          if (want_arg[s * C + c] >= 0) dxw(want_arg[s * C + c], c) += d_out.at(s, c);
      cpu::segment_max_backward(d_out, arg, d_x);
      require_close(d_x, dxw, 0, 1e-7, "segment max backward");
      REQUIRE(pad_intact(d_x));
      cpu::segment_max_backward(d_out, arg, Tensor());  // undefined: no-op
    }
}

TEST_CASE("segment max: ties go to the first row, NaN propagates", "[pooling][segment_max]") {
  const std::vector<std::int64_t> seg = {0, 4, 9};
  Tensor x = Tensor::from(9, 3, {1, 5, 0,   //
                                 7, 5, 0,   //
                                 7, 2, 0,   //
                                 3, 5, 0,   // segment 0: col0 tie rows 1/2, col1 rows 0/1/3, col2 all equal
                                 2, 2, 1,   //
                                 9, 2, NAN,  //
                                 9, 8, 4,   //
                                 1, NAN, 4,  //
                                 9, 8, 4});  // segment 1
  Tensor out = Tensor::empty(2, 3), arg = Tensor::empty(2, 3, DType::i32);
  cpu::segment_max_forward(x, seg, out, arg);
  REQUIRE(arg.at_i32(0, 0) == 1);
  REQUIRE(arg.at_i32(0, 1) == 0);
  REQUIRE(arg.at_i32(0, 2) == 0);
  REQUIRE(out.at(0, 0) == 7.0f);
  REQUIRE(arg.at_i32(1, 0) == 5);
  REQUIRE(out.at(1, 0) == 9.0f);
  REQUIRE(arg.at_i32(1, 1) == 7);  // the NaN
  REQUIRE(std::isnan(out.at(1, 1)));
  REQUIRE(arg.at_i32(1, 2) == 5);
  REQUIRE(std::isnan(out.at(1, 2)));
  // A single segment of one row, and no segments at all.
  Tensor one = Tensor::from(1, 2, {-3, 4});
  Tensor o1 = Tensor::empty(1, 2), a1 = Tensor::empty(1, 2, DType::i32);
  const std::vector<std::int64_t> seg1 = {0, 1};
  cpu::segment_max_forward(one, seg1, o1, a1);
  REQUIRE((o1.at(0, 0) == -3.0f && o1.at(0, 1) == 4.0f && a1.at_i32(0, 0) == 0 && a1.at_i32(0, 1) == 0));
  const std::vector<std::int64_t> seg0 = {0};
  cpu::segment_max_forward(Tensor::zeros(0, 2), seg0, Tensor::zeros(0, 2), Tensor::zeros(0, 2, DType::i32));
}

TEST_CASE("segment max / broadcast: 1 vs 2 threads bitwise", "[pooling][determinism]") {
  Rng rng(102);
  const std::int64_t n = 30011, C = 70;
  const std::vector<std::int64_t> seg = {0, 10000, 10000, 25000, n};
  Tensor x = random(rng, n, C, true);
  Tensor d_out = random(rng, 4, C, false), d_big = random(rng, n, C, true);
  auto run = [&](int threads) {
    Threads th(threads);
    Tensor out = Tensor::empty(4, C), arg = Tensor::empty(4, C, DType::i32), dx = Tensor::zeros(n, C);
    cpu::segment_max_forward(x, seg, out, arg);
    cpu::segment_max_backward(d_out, arg, dx);
    Tensor b = Tensor::empty(n, C), db = Tensor::zeros(4, C);
    cpu::broadcast_segments_forward(d_out, seg, b);
    cpu::broadcast_segments_backward(d_big, seg, db);
    return std::vector<Tensor>{out, arg, dx, b, db};
  };
  const auto a = run(1), b = run(2);
  for (std::size_t i = 0; i < a.size(); ++i) {
    INFO("output " << i);
    REQUIRE(bitwise_equal(a[i], b[i]));
  }
}

TEST_CASE("segment max: bad arguments throw naming the argument", "[pooling][errors]") {
  Tensor x = Tensor::zeros(10, 4), out = Tensor::zeros(2, 4), arg = Tensor::zeros(2, 4, DType::i32);
  const std::vector<std::int64_t> good = {0, 3, 10}, bad_end = {0, 3, 9}, bad_start = {1, 3, 10}, dec = {0, 6, 3, 10};
  REQUIRE_NOTHROW(cpu::segment_max_forward(x, good, out, arg));
  REQUIRE_THROWS_WITH(cpu::segment_max_forward(x, bad_end, out, arg), Contains("seg_ptr"));
  REQUIRE_THROWS_WITH(cpu::segment_max_forward(x, bad_start, out, arg), Contains("seg_ptr"));
  REQUIRE_THROWS_WITH(cpu::segment_max_forward(x, dec, Tensor::zeros(3, 4), Tensor::zeros(3, 4, DType::i32)),
                      Contains("seg_ptr: decreases"));
  REQUIRE_THROWS_WITH(cpu::segment_max_forward(x, good, Tensor::zeros(3, 4), arg),
                      Contains("segment_max_forward: out: expected shape [2, 4], got [3, 4]"));
  REQUIRE_THROWS_WITH(cpu::segment_max_forward(x, good, out, Tensor::zeros(2, 4)),
                      Contains("segment_max_forward: argmax") && Contains("int32"));
  Tensor wild = Tensor::from_i32(2, 4, {0, 1, 2, 3, 4, 5, 6, 10});
  REQUIRE_THROWS_WITH(cpu::segment_max_backward(out, wild, x), Contains("segment_max_backward: argmax") && Contains("[1, 3]"));
  REQUIRE_THROWS_WITH(cpu::segment_max_backward(out, arg, Tensor::zeros(10, 5)), Contains("segment_max_backward: d_x"));
}

// ==== broadcast ========================================================================

TEST_CASE("broadcast segments: forward and backward with empty segments", "[pooling][broadcast]") {
  Rng rng(111);
  const std::vector<std::int64_t> seg = {0, 0, 5, 5, 17, 18, 18, 40};
  const std::int64_t n = 40, S = 7;
  for (std::int64_t C : {1, 16, 33})
    for (int strided = 0; strided < 2; ++strided) {
      INFO("C " << C << " strided " << strided);
      Tensor x = random(rng, S, C, strided);
      Tensor out = make(n, C, !strided);
      cpu::broadcast_segments_forward(x, seg, out);
      Mat want(n, C);
      for (std::int64_t s = 0; s < S; ++s)
        for (std::int64_t r = seg[s]; r < seg[s + 1]; ++r)
          for (std::int64_t c = 0; c < C; ++c) want(r, c) = x.at(s, c);
      require_close(out, want, 0, 0, "broadcast");
      REQUIRE(pad_intact(out));

      Tensor d_out = random(rng, n, C, strided), d_x = random(rng, S, C, !strided);
      Mat dw = ref::to_mat(d_x);
      for (std::int64_t s = 0; s < S; ++s)
        for (std::int64_t r = seg[s]; r < seg[s + 1]; ++r)
          for (std::int64_t c = 0; c < C; ++c) dw(s, c) += d_out.at(r, c);
      cpu::broadcast_segments_backward(d_out, seg, d_x);
      require_close(d_x, dw, 1e-6, 1e-6, "broadcast backward");
      REQUIRE(pad_intact(d_x));
    }
  const std::vector<std::int64_t> seg2 = {0, 4};
  REQUIRE_THROWS_WITH(cpu::broadcast_segments_forward(Tensor::zeros(2, 3), seg2, Tensor::zeros(4, 3)),
                      Contains("broadcast_segments_forward: x: expected shape [1, 3], got [2, 3]"));
  REQUIRE_THROWS_WITH(cpu::broadcast_segments_backward(Tensor::zeros(4, 3), seg2, Tensor::zeros(1, 2)),
                      Contains("broadcast_segments_backward: d_x"));
  REQUIRE_THROWS_WITH(cpu::broadcast_segments_backward(Tensor::zeros(5, 3), seg2, Tensor::zeros(1, 3)),
                      Contains("seg_ptr"));
}

// ==== neighbour mean ====================================================================

TEST_CASE("neighbour mean: non-symmetric neighbour graph with empty neighbour sets", "[pooling][neighbour_mean]") {
  Rng rng(121);
  const std::int64_t n = 50;
  const auto lists = random_lists(rng, n, 6, {7, 30, 49});
  const CsrGraph g = ref::csr_from_lists(lists);
  REQUIRE_FALSE(g.symmetric);
  REQUIRE_NOTHROW(g.validate());
  {
    // The library's builder gives the same graph.
    const CsrGraph h = graph_from_neighbour_lists(n, lists);
    REQUIRE(h.indptr == g.indptr);
    REQUIRE(h.indices == g.indices);
    REQUIRE(h.out_ptr == g.out_ptr);
    REQUIRE(h.out_dst == g.out_dst);
    REQUIRE(h.out_edge == g.out_edge);
  }
  for (std::int64_t C : {1, 13, 64})
    for (int strided = 0; strided < 2; ++strided) {
      INFO("C " << C << " strided " << strided);
      Tensor x = random(rng, n, C, strided);
      Tensor out = make(n, C, !strided);
      out.fill_(5.0f);
      cpu::neighbour_mean_forward(g, x, out);
      require_close(out, ref::neighbour_mean(lists, ref::to_mat(x)), 1e-6, 1e-6, "forward");
      REQUIRE(pad_intact(out));
      for (std::int64_t c = 0; c < C; ++c) REQUIRE(out.at(7, c) == 0.0f);  // empty neighbour set

      Tensor d_out = random(rng, n, C, !strided), d_x = random(rng, n, C, strided);
      const Mat want = plus(ref::to_mat(d_x), ref::neighbour_mean_backward(lists, ref::to_mat(d_out)));
      cpu::neighbour_mean_backward(g, d_out, d_x);
      require_close(d_x, want, 1e-6, 1e-6, "backward");
      REQUIRE(pad_intact(d_x));
      cpu::neighbour_mean_backward(g, d_out, Tensor());
    }
}

TEST_CASE("neighbour mean: a graph where nobody has neighbours, and a single node", "[pooling][neighbour_mean]") {
  const std::vector<std::vector<std::int32_t>> none(4);
  const CsrGraph g = ref::csr_from_lists(none);
  Tensor x = Tensor::full(4, 3, 2.0f), out = Tensor::full(4, 3, 9.0f), dx = Tensor::zeros(4, 3);
  cpu::neighbour_mean_forward(g, x, out);
  for (float v : out.to_vector()) REQUIRE(v == 0.0f);
  cpu::neighbour_mean_backward(g, x, dx);
  for (float v : dx.to_vector()) REQUIRE(v == 0.0f);
  const CsrGraph one = ref::csr_from_lists({{0}});
  Tensor x1 = Tensor::from(1, 2, {3, -4}), o1 = Tensor::empty(1, 2);
  cpu::neighbour_mean_forward(one, x1, o1);
  REQUIRE((o1.at(0, 0) == 3.0f && o1.at(0, 1) == -4.0f));
}

TEST_CASE("neighbour mean: 1 vs 2 threads bitwise on a large graph", "[pooling][neighbour_mean][determinism]") {
  Rng rng(122);
  const std::int64_t n = 20000, C = 48;
  const auto lists = random_lists(rng, n, 16, {5, 6, 19999});
  const CsrGraph g = ref::csr_from_lists(lists);
  Tensor x = random(rng, n, C, true), d_out = random(rng, n, C, false);
  auto run = [&](int threads) {
    Threads th(threads);
    Tensor out = Tensor::empty(n, C), dx = Tensor::zeros(n, C);
    cpu::neighbour_mean_forward(g, x, out);
    cpu::neighbour_mean_backward(g, d_out, dx);
    return std::pair<Tensor, Tensor>(out, dx);
  };
  const auto a = run(1), b = run(2);
  REQUIRE(bitwise_equal(a.first, b.first));
  REQUIRE(bitwise_equal(a.second, b.second));
  // and right, on a sample of rows
  const Mat want = ref::neighbour_mean(lists, ref::to_mat(x));
  require_close(a.first, want, 1e-6, 1e-6, "large forward");
}

TEST_CASE("neighbour mean: bad arguments throw naming the argument", "[pooling][neighbour_mean][errors]") {
  const CsrGraph g = ref::csr_from_lists({{1}, {0, 2}, {}});
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_forward(g, Tensor::zeros(4, 2), Tensor::zeros(3, 2)),
                      Contains("neighbour_mean_forward: x: expected shape [3, *], got [4, 2]"));
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_forward(g, Tensor::zeros(3, 2), Tensor::zeros(3, 3)),
                      Contains("neighbour_mean_forward: out"));
  Tensor buf = Tensor::zeros(3, 4);
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_forward(g, buf, buf), Contains("overlaps"));
  REQUIRE_NOTHROW(cpu::neighbour_mean_forward(g, buf.cols_slice(0, 2), buf.cols_slice(2, 4)));
  CsrGraph no_t = g;
  no_t.out_ptr.clear();
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_backward(no_t, Tensor::zeros(3, 2), Tensor::zeros(3, 2)),
                      Contains("neighbour_mean_backward: nbr"));
  CsrGraph broken = g;
  broken.indptr.pop_back();
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_forward(broken, Tensor::zeros(3, 2), Tensor::zeros(3, 2)),
                      Contains("neighbour_mean_forward: nbr"));
  REQUIRE_THROWS_WITH(cpu::neighbour_mean_backward(g, Tensor::zeros(3, 2), Tensor::zeros(2, 2)),
                      Contains("neighbour_mean_backward: d_x"));
}
