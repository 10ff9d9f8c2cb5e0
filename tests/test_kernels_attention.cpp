// Graph-attention kernels (projection, edge softmax, aggregation, fused GAT),
// forward and backward, against the double-precision reference, at every SIMD
// level the CPU supports and with 1 and 2 OpenMP threads (backward results
// must be bitwise identical across thread counts).
#include <omp.h>

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "src/backends/cpu/aggregation.hpp"
#include "src/backends/cpu/attention_projection.hpp"
#include "src/backends/cpu/attn_simd.hpp"
#include "src/backends/cpu/edge_softmax.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/simd.hpp"
#include "mesh_fixtures.hpp"
#include "reference/attention_reference.hpp"
#include "test_util.hpp"

using gatcore::CsrGraph;
using gatcore::Tensor;
using testutil::make_tensor;
using testutil::random_tensor;
namespace cpu = gatcore::cpu;

namespace {

constexpr double kTol = 1e-5;

struct GraphCase {
  std::string name;
  CsrGraph g;
};

// Random graphs with isolated nodes and rows without self-loops, a hub row of
// 699 neighbours (and a source feeding every node), one-node graphs, and a
// block-diagonal batch including a mesh.
const std::vector<GraphCase>& graph_cases() {
  static const std::vector<GraphCase> cases = [] {
    std::vector<GraphCase> c;
    testutil::RandomGraphOptions o;
    o.max_degree = 12;
    o.isolated = 5;
    c.push_back({"random", testutil::random_graph(600, 1, o)});
    o = {};
    o.max_degree = 8;
    o.self_loops = false;
    o.isolated = 3;
    c.push_back({"random-no-self-loops", testutil::random_graph(600, 2, o)});
    {
      std::mt19937 rng(3);
      std::uniform_int_distribution<std::int32_t> node(0, 699);
      testutil::Adjacency adj(700);
      for (std::int32_t j = 1; j < 700; ++j) adj[0].push_back(j);  // hub row
      for (std::int32_t i = 1; i < 700; ++i) {
        adj[i] = {i, 1, node(rng), node(rng)};  // node 1 feeds every row
      }
      c.push_back({"hub", testutil::graph_from_adjacency(adj)});
    }
    c.push_back({"one-node-self-loop", testutil::graph_from_adjacency({{0}})});
    c.push_back({"one-node-isolated", testutil::graph_from_adjacency({{}})});
    {
      testutil::RandomGraphOptions s;
      s.symmetric = true;
      s.max_degree = 4;
      std::vector<CsrGraph> parts{testutil::random_graph(40, 4, s), fixtures::grid_graph(12, 10, 2),
                                  testutil::random_graph(300, 5, s)};
      c.push_back({"batch", testutil::batch_of(parts)});
    }
    return c;
  }();
  return cases;
}

struct Shape {
  int H, F;
};
const std::vector<Shape> kShapes{{8, 8}, {3, 5}, {1, 1}, {2, 20}, {8, 3}};

std::vector<cpu::SimdLevel> levels() {
  std::vector<cpu::SimdLevel> l{cpu::SimdLevel::scalar};
  if (cpu::detected_simd_level() >= cpu::SimdLevel::avx2) l.push_back(cpu::SimdLevel::avx2);
  if (cpu::detected_simd_level() >= cpu::SimdLevel::avx512) l.push_back(cpu::SimdLevel::avx512);
  return l;
}

// Restores the SIMD level and thread count when a test ends.
struct Restore {
  int threads = omp_get_max_threads();
  ~Restore() {
    cpu::set_simd_level(cpu::detected_simd_level());
    omp_set_num_threads(threads);
  }
};

// max |got - want| / (|want| + rms(want) + 1e-30)
double rel_err(const Tensor& got, const ref::DMat& want) {
  if (got.rows() != want.rows || got.cols() != want.cols) return INFINITY;
  double ss = 0;
  for (double v : want.v) ss += v * v;
  const double rms = want.v.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(want.v.size()));
  double worst = 0;
  for (std::int64_t r = 0; r < want.rows; ++r)
    for (std::int64_t c = 0; c < want.cols; ++c) {
      const double g = got.at(r, c), w = want(r, c);
      if (!std::isfinite(g)) return INFINITY;
      worst = std::max(worst, std::abs(g - w) / (std::abs(w) + rms + 1e-30));
    }
  return worst;
}

#define CHECK_CLOSE(got, want, tol)                                                  \
  do {                                                                               \
    const double err_ = rel_err((got), (want));                                      \
    INFO(#got << " relative error " << err_);                                        \
    CHECK(err_ <= (tol));                                                            \
    CHECK(testutil::guards_intact(got));                                             \
  } while (0)

// Runs `run` (which returns the kernel outputs) at every SIMD level with 1 and
// 2 threads; `check` compares each run with the reference; outputs of the two
// thread counts must be bitwise identical.
void sweep(const std::string& ctx, const std::function<std::vector<Tensor>()>& run,
           const std::function<void(const std::vector<Tensor>&)>& check) {
  Restore restore;
  for (cpu::SimdLevel lvl : levels()) {
    cpu::set_simd_level(lvl);
    std::vector<Tensor> first;
    for (int nt : {1, 2}) {
      omp_set_num_threads(nt);
      INFO(ctx << " simd=" << cpu::simd_level_name(lvl) << " threads=" << nt);
      std::vector<Tensor> outs = run();
      check(outs);
      if (nt == 1) {
        first = outs;
      } else {
        for (std::size_t k = 0; k < outs.size(); ++k) {
          INFO("output " << k << " differs between 1 and 2 threads");
          CHECK(testutil::bitwise_equal(first[k], outs[k]));
        }
      }
    }
  }
}

std::string context(const std::string& graph, Shape s, bool strided) {
  std::ostringstream os;
  os << "graph=" << graph << " H=" << s.H << " F=" << s.F << (strided ? " strided" : " contiguous");
  return os.str();
}

// Every (graph, shape) combination, contiguous and (for the H = 8 shapes and
// the odd 3 x 5) as strided column-slice views. Graphs with more than
// kParallelMin work units (edges + nodes) run their 2-thread sweeps really in
// parallel; the one-node graphs stay on the calling thread.
template <class Fn>
void for_each_config(Fn&& fn) {
  std::uint32_t seed = 100;
  for (const GraphCase& gc : graph_cases())
    for (Shape s : kShapes)
      for (bool strided : {false, true})
        if (!strided || s.H == 8 || s.H == 3) fn(gc, s, strided, ++seed);
}

}  // namespace

TEST_CASE("test graphs are large enough to run kernels on 2 threads", "[attention][setup]") {
  for (const GraphCase& gc : graph_cases())
    if (gc.g.num_nodes > 1) {
      INFO(gc.name);
      CHECK(gc.g.num_edges() + gc.g.num_nodes >= cpu::attn::kParallelMin);
    }
}

// ---- projection -----------------------------------------------------------------

TEST_CASE("attention_projection forward and backward match the reference", "[attention][projection]") {
  std::uint32_t seed = 7;
  for (std::int64_t n : {1, 37, 1500})
    for (Shape s : kShapes)
      for (bool strided : {false, true}) {
        std::mt19937 rng(++seed);
        const int H = s.H, F = s.F;
        Tensor z = random_tensor(n, H * F, rng, -1, 1, strided);
        Tensor al = random_tensor(H, F, rng, -1, 1, strided), ar = random_tensor(H, F, rng, -1, 1, strided);
        Tensor d_el = random_tensor(n, H, rng, -1, 1, strided), d_er = random_tensor(n, H, rng, -1, 1, strided);
        Tensor dz0 = random_tensor(n, H * F, rng, -1, 1, strided);
        Tensor dal0 = random_tensor(H, F, rng, -1, 1, strided), dar0 = random_tensor(H, F, rng, -1, 1, strided);
        ref::DMat el_ref, er_ref, dz_ref, dal_ref, dar_ref;
        ref::projection(ref::to_d(z), ref::to_d(al), ref::to_d(ar), el_ref, er_ref);
        ref::projection_backward(ref::to_d(z), ref::to_d(al), ref::to_d(ar), ref::to_d(d_el), ref::to_d(d_er), dz_ref,
                                 dal_ref, dar_ref);
        dz_ref = ref::plus(dz_ref, ref::to_d(dz0));
        dal_ref = ref::plus(dal_ref, ref::to_d(dal0));
        dar_ref = ref::plus(dar_ref, ref::to_d(dar0));
        const std::string ctx = "n=" + std::to_string(n) + " " + context("-", s, strided);
        sweep(
            ctx,
            [&] {
              Tensor el = make_tensor(n, H, strided), er = make_tensor(n, H, strided);
              cpu::attention_projection_forward(z, al, ar, el, er);
              return std::vector<Tensor>{el, er};
            },
            [&](const std::vector<Tensor>& o) {
              CHECK_CLOSE(o[0], el_ref, kTol);
              CHECK_CLOSE(o[1], er_ref, kTol);
            });
        sweep(
            ctx,
            [&] {
              Tensor dz = testutil::copy_like(dz0, strided), dal = testutil::copy_like(dal0, strided),
                     dar = testutil::copy_like(dar0, strided);
              cpu::attention_projection_backward(z, al, ar, d_el, d_er, dz, dal, dar);
              return std::vector<Tensor>{dz, dal, dar};
            },
            [&](const std::vector<Tensor>& o) {
              CHECK_CLOSE(o[0], dz_ref, kTol);
              CHECK_CLOSE(o[1], dal_ref, kTol);
              CHECK_CLOSE(o[2], dar_ref, kTol);
            });
        // Only some gradients wanted.
        Tensor dal = testutil::copy_like(dal0, strided);
        cpu::attention_projection_backward(z, al, ar, d_el, d_er, Tensor{}, dal, Tensor{});
        CHECK_CLOSE(dal, dal_ref, kTol);
      }
}

TEST_CASE("attention_projection_forward_rows gives the whole call's rows bitwise, touching no others",
          "[attention][projection]") {
  Restore restore;
  std::uint32_t seed = 70;
  for (Shape s : kShapes)
    for (cpu::SimdLevel lvl : levels()) {
      cpu::set_simd_level(lvl);
      std::mt19937 rng(++seed);
      const std::int64_t n = 300;
      const int H = s.H, F = s.F;
      const Tensor z = random_tensor(n, H * F, rng, -1, 1, true);
      const Tensor al = random_tensor(H, F, rng, -1, 1, true), ar = random_tensor(H, F, rng, -1, 1, false);
      Tensor el = Tensor::empty(n, H), er = Tensor::empty(n, H);
      cpu::attention_projection_forward(z, al, ar, el, er);
      Tensor el2 = Tensor::full(n, H, 7.f), er2 = Tensor::full(n, H, 7.f);
      INFO("H=" << H << " F=" << F << " simd=" << cpu::simd_level_name(lvl));
      for (std::int64_t r0 : {0, 120, 240}) cpu::attention_projection_forward_rows(z, al, ar, el2, er2, r0, r0 + 60);
      for (std::int64_t r = 0; r < n; ++r) {
        const bool done = r % 120 < 60;
        for (int k = 0; k < H; ++k) {
          CHECK(el2.at(r, k) == (done ? el.at(r, k) : 7.f));
          CHECK(er2.at(r, k) == (done ? er.at(r, k) : 7.f));
        }
      }
      CHECK_THROWS_WITH(cpu::attention_projection_forward_rows(z, al, ar, el2, er2, 250, 301),
                        Catch::Contains("rows [250, 301) outside [0, 300)"));
    }
}

// ---- edge softmax -----------------------------------------------------------------

TEST_CASE("edge_softmax_additive forward and backward match the reference", "[attention][softmax]") {
  for_each_config([](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    const int H = s.H;
    const float slope = 0.2f;
    std::mt19937 rng(seed);
    Tensor el = random_tensor(n, H, rng, -2, 2, strided), er = random_tensor(n, H, rng, -2, 2, strided);
    const ref::DMat alpha_ref = ref::softmax(g, ref::logits_additive(g, ref::to_d(el), ref::to_d(er), slope));
    Tensor alpha = testutil::copy_like(ref::to_f(alpha_ref), strided);
    Tensor d_alpha = random_tensor(E, H, rng, -1, 1, strided);
    Tensor del0 = random_tensor(n, H, rng, -1, 1, strided), der0 = random_tensor(n, H, rng, -1, 1, strided);
    ref::DMat del_ref, der_ref;
    ref::additive_logit_backward(g, ref::to_d(el), ref::to_d(er), slope,
                                 ref::softmax_backward(g, ref::to_d(alpha), ref::to_d(d_alpha)), del_ref, der_ref);
    del_ref = ref::plus(del_ref, ref::to_d(del0));
    der_ref = ref::plus(der_ref, ref::to_d(der0));
    const std::string ctx = context(gc.name, s, strided);
    sweep(
        ctx,
        [&] {
          Tensor a = make_tensor(E, H, strided);
          cpu::edge_softmax_additive_forward(g, el, er, slope, a);
          return std::vector<Tensor>{a};
        },
        [&](const std::vector<Tensor>& o) { CHECK_CLOSE(o[0], alpha_ref, kTol); });
    sweep(
        ctx,
        [&] {
          Tensor del = testutil::copy_like(del0, strided), der = testutil::copy_like(der0, strided);
          cpu::edge_softmax_additive_backward(g, el, er, slope, alpha, d_alpha, del, der);
          return std::vector<Tensor>{del, der};
        },
        [&](const std::vector<Tensor>& o) {
          CHECK_CLOSE(o[0], del_ref, kTol);
          CHECK_CLOSE(o[1], der_ref, kTol);
        });
    // One side only.
    Tensor der = testutil::copy_like(der0, strided);
    cpu::edge_softmax_additive_backward(g, el, er, slope, alpha, d_alpha, Tensor{}, der);
    CHECK_CLOSE(der, der_ref, kTol);
  });
}

TEST_CASE("edge_softmax_dot forward and backward match the reference", "[attention][softmax]") {
  for_each_config([](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    const int H = s.H, F = s.F;
    const float scale = 1.0f / std::sqrt(static_cast<float>(F));
    std::mt19937 rng(seed);
    Tensor h = random_tensor(n, H * F, rng, -1, 1, strided);
    const ref::DMat alpha_ref = ref::softmax(g, ref::logits_dot(g, ref::to_d(h), H, scale));
    Tensor alpha = testutil::copy_like(ref::to_f(alpha_ref), strided);
    Tensor d_alpha = random_tensor(E, H, rng, -1, 1, strided);
    Tensor dh0 = random_tensor(n, H * F, rng, -1, 1, strided);
    const ref::DMat dh_ref = ref::plus(
        ref::dot_logit_backward(g, ref::to_d(h), H, scale,
                                ref::softmax_backward(g, ref::to_d(alpha), ref::to_d(d_alpha))),
        ref::to_d(dh0));
    const std::string ctx = context(gc.name, s, strided);
    sweep(
        ctx,
        [&] {
          Tensor a = make_tensor(E, H, strided);
          cpu::edge_softmax_dot_forward(g, h, H, scale, a);
          return std::vector<Tensor>{a};
        },
        [&](const std::vector<Tensor>& o) { CHECK_CLOSE(o[0], alpha_ref, kTol); });
    sweep(
        ctx,
        [&] {
          Tensor dh = testutil::copy_like(dh0, strided);
          cpu::edge_softmax_dot_backward(g, h, H, scale, alpha, d_alpha, dh);
          return std::vector<Tensor>{dh};
        },
        [&](const std::vector<Tensor>& o) { CHECK_CLOSE(o[0], dh_ref, kTol); });
  });
}

// ---- aggregation ------------------------------------------------------------------

TEST_CASE("aggregate forward and backward match the reference", "[attention][aggregate]") {
  for_each_config([](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    const int H = s.H, F = s.F;
    std::mt19937 rng(seed);
    Tensor z = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor alpha = random_tensor(E, H, rng, 0, 1, strided);
    Tensor d_out = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor dz0 = random_tensor(n, H * F, rng, -1, 1, strided);
    const ref::DMat out_ref = ref::aggregate(g, ref::to_d(alpha), ref::to_d(z));
    ref::DMat da_ref, dz_ref;
    ref::aggregate_backward(g, ref::to_d(alpha), ref::to_d(z), ref::to_d(d_out), da_ref, dz_ref);
    dz_ref = ref::plus(dz_ref, ref::to_d(dz0));
    const std::string ctx = context(gc.name, s, strided);
    sweep(
        ctx,
        [&] {
          Tensor out = make_tensor(n, H * F, strided);
          out.fill_(std::nanf(""));  // overwritten, isolated rows included
          cpu::aggregate_forward(g, alpha, z, out);
          return std::vector<Tensor>{out};
        },
        [&](const std::vector<Tensor>& o) { CHECK_CLOSE(o[0], out_ref, kTol); });
    sweep(
        ctx,
        [&] {
          Tensor da = make_tensor(E, H, strided), dz = testutil::copy_like(dz0, strided);
          da.fill_(std::nanf(""));  // overwritten
          cpu::aggregate_backward(g, alpha, z, d_out, da, dz);
          return std::vector<Tensor>{da, dz};
        },
        [&](const std::vector<Tensor>& o) {
          CHECK_CLOSE(o[0], da_ref, kTol);
          CHECK_CLOSE(o[1], dz_ref, kTol);
        });
    // Each output alone.
    Tensor da = make_tensor(E, H, strided), dz = testutil::copy_like(dz0, strided);
    cpu::aggregate_backward(g, alpha, z, d_out, da, Tensor{});
    CHECK_CLOSE(da, da_ref, kTol);
    cpu::aggregate_backward(g, alpha, z, d_out, Tensor{}, dz);
    CHECK_CLOSE(dz, dz_ref, kTol);
  });
}

// ---- fused ------------------------------------------------------------------------

TEST_CASE("gat_fused_additive matches the reference and the unfused kernels", "[attention][fused]") {
  for_each_config([](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    const int H = s.H, F = s.F;
    const float slope = 0.2f;
    std::mt19937 rng(seed);
    Tensor z = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor el = random_tensor(n, H, rng, -3, 3, strided), er = random_tensor(n, H, rng, -3, 3, strided);
    Tensor d_out = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor dz0 = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor del0 = random_tensor(n, H, rng, -1, 1, strided), der0 = random_tensor(n, H, rng, -1, 1, strided);
    const ref::DMat alpha_ref = ref::softmax(g, ref::logits_additive(g, ref::to_d(el), ref::to_d(er), slope));
    const ref::DMat out_ref = ref::aggregate(g, alpha_ref, ref::to_d(z));
    // Backward from the float alpha the forward hands over.
    Tensor alpha = testutil::copy_like(ref::to_f(alpha_ref), strided);
    ref::DMat da, dz_ref, del_ref, der_ref;
    ref::aggregate_backward(g, ref::to_d(alpha), ref::to_d(z), ref::to_d(d_out), da, dz_ref);
    ref::additive_logit_backward(g, ref::to_d(el), ref::to_d(er), slope, ref::softmax_backward(g, ref::to_d(alpha), da),
                                 del_ref, der_ref);
    dz_ref = ref::plus(dz_ref, ref::to_d(dz0));
    del_ref = ref::plus(del_ref, ref::to_d(del0));
    der_ref = ref::plus(der_ref, ref::to_d(der0));
    const std::string ctx = context(gc.name, s, strided);
    sweep(
        ctx,
        [&] {
          Tensor out = make_tensor(n, H * F, strided), a = make_tensor(E, H, strided);
          out.fill_(std::nanf(""));
          cpu::gat_fused_additive_forward(g, z, el, er, slope, out, a);
          // unfused at the same level
          Tensor a2 = make_tensor(E, H, strided), out2 = make_tensor(n, H * F, strided);
          cpu::edge_softmax_additive_forward(g, el, er, slope, a2);
          cpu::aggregate_forward(g, a2, z, out2);
          return std::vector<Tensor>{out, a, out2, a2};
        },
        [&](const std::vector<Tensor>& o) {
          CHECK_CLOSE(o[0], out_ref, kTol);
          CHECK_CLOSE(o[1], alpha_ref, kTol);
          CHECK_CLOSE(o[0], ref::to_d(o[2]), kTol);  // fused == unfused
          CHECK_CLOSE(o[1], ref::to_d(o[3]), kTol);
        });
    sweep(
        ctx,
        [&] {
          Tensor dz = testutil::copy_like(dz0, strided), del = testutil::copy_like(del0, strided),
                 der = testutil::copy_like(der0, strided);
          cpu::gat_fused_additive_backward(g, z, el, er, slope, alpha, d_out, dz, del, der);
          return std::vector<Tensor>{dz, del, der};
        },
        [&](const std::vector<Tensor>& o) {
          CHECK_CLOSE(o[0], dz_ref, kTol);
          CHECK_CLOSE(o[1], del_ref, kTol);
          CHECK_CLOSE(o[2], der_ref, kTol);
        });
    // Subsets of the gradients.
    Tensor dz = testutil::copy_like(dz0, strided), del = testutil::copy_like(del0, strided),
           der = testutil::copy_like(der0, strided);
    cpu::gat_fused_additive_backward(g, z, el, er, slope, alpha, d_out, dz, Tensor{}, Tensor{});
    CHECK_CLOSE(dz, dz_ref, kTol);
    cpu::gat_fused_additive_backward(g, z, el, er, slope, alpha, d_out, Tensor{}, del, Tensor{});
    CHECK_CLOSE(del, del_ref, kTol);
    cpu::gat_fused_additive_backward(g, z, el, er, slope, alpha, d_out, Tensor{}, Tensor{}, der);
    CHECK_CLOSE(der, der_ref, kTol);
  });
}

TEST_CASE("gat_fused_dot matches the reference and the unfused kernels", "[attention][fused]") {
  for_each_config([](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    const int H = s.H, F = s.F;
    const float scale = 1.0f / std::sqrt(static_cast<float>(F));
    std::mt19937 rng(seed);
    Tensor z = random_tensor(n, H * F, rng, -1.5, 1.5, strided);
    Tensor d_out = random_tensor(n, H * F, rng, -1, 1, strided);
    Tensor dz0 = random_tensor(n, H * F, rng, -1, 1, strided);
    const ref::DMat alpha_ref = ref::softmax(g, ref::logits_dot(g, ref::to_d(z), H, scale));
    const ref::DMat out_ref = ref::aggregate(g, alpha_ref, ref::to_d(z));
    Tensor alpha = testutil::copy_like(ref::to_f(alpha_ref), strided);
    ref::DMat da, dz_agg;
    ref::aggregate_backward(g, ref::to_d(alpha), ref::to_d(z), ref::to_d(d_out), da, dz_agg);
    const ref::DMat dz_ref = ref::plus(
        ref::plus(dz_agg, ref::dot_logit_backward(g, ref::to_d(z), H, scale, ref::softmax_backward(g, ref::to_d(alpha), da))),
        ref::to_d(dz0));
    const std::string ctx = context(gc.name, s, strided);
    sweep(
        ctx,
        [&] {
          Tensor out = make_tensor(n, H * F, strided), a = make_tensor(E, H, strided);
          out.fill_(std::nanf(""));
          cpu::gat_fused_dot_forward(g, z, H, scale, out, a);
          Tensor a2 = make_tensor(E, H, strided), out2 = make_tensor(n, H * F, strided);
          cpu::edge_softmax_dot_forward(g, z, H, scale, a2);
          cpu::aggregate_forward(g, a2, z, out2);
          return std::vector<Tensor>{out, a, out2, a2};
        },
        [&](const std::vector<Tensor>& o) {
          CHECK_CLOSE(o[0], out_ref, kTol);
          CHECK_CLOSE(o[1], alpha_ref, kTol);
          CHECK_CLOSE(o[0], ref::to_d(o[2]), kTol);
          CHECK_CLOSE(o[1], ref::to_d(o[3]), kTol);
        });
    sweep(
        ctx,
        [&] {
          Tensor dz = testutil::copy_like(dz0, strided);
          cpu::gat_fused_dot_backward(g, z, H, scale, alpha, d_out, dz);
          return std::vector<Tensor>{dz};
        },
        [&](const std::vector<Tensor>& o) { CHECK_CLOSE(o[0], dz_ref, kTol); });
  });
}

// ---- numerics ---------------------------------------------------------------------

namespace {
__attribute__((target("avx2,fma"))) void exp_with_avx2(const float* x, float* y, int n) {
  for (int i = 0; i + 8 <= n; i += 8) _mm256_storeu_ps(y + i, gatcore::cpu::attn::exp_avx2(_mm256_loadu_ps(x + i)));
}
__attribute__((target("avx512f,avx512bw,avx512vl,avx2,fma"))) void exp_with_avx512(const float* x, float* y, int n) {
  for (int i = 0; i + 16 <= n; i += 16)
    _mm512_storeu_ps(y + i, gatcore::cpu::attn::exp_avx512(_mm512_loadu_ps(x + i)));
  for (int i = 0; i + 8 <= n; i += 8)  // the ymm variant into the second half
    _mm256_storeu_ps(y + n + i, gatcore::cpu::attn::exp_avx512vl(_mm256_loadu_ps(x + i)));
}
}  // namespace

TEST_CASE("vectorised exp is accurate to ~1e-7 relative and safe at the extremes", "[attention][exp]") {
  std::vector<float> x;
  for (int i = 0; i <= 200000; ++i) x.push_back(-87.0f + 175.0f * static_cast<float>(i) / 200000.0f);  // [-87, 88]
  x.resize(x.size() / 16 * 16);
  const int n = static_cast<int>(x.size());
  auto max_rel = [&](const float* y) {
    double worst = 0;
    for (int i = 0; i < n; ++i) {
      const double want = std::exp(static_cast<double>(x[i]));
      worst = std::max(worst, std::abs(y[i] - want) / want);
    }
    return worst;
  };
  const auto best = cpu::detected_simd_level();
  std::vector<float> y(2 * x.size());
  if (best >= cpu::SimdLevel::avx2) {
    exp_with_avx2(x.data(), y.data(), n);
    CHECK(max_rel(y.data()) < 3e-7);
    const float extremes[8] = {-1e4f, -200.0f, -88.0f, -87.5f, 0.0f, -0.0f, 1e-30f, -INFINITY};
    float out[8];
    exp_with_avx2(extremes, out, 8);
    for (int i = 0; i < 4; ++i) CHECK((out[i] >= 0.0f && out[i] < 1.2e-38f));
    CHECK(out[4] == 1.0f);
    CHECK(out[5] == 1.0f);
    CHECK(out[6] == 1.0f);
    CHECK(out[7] == 0.0f);
  }
  if (best >= cpu::SimdLevel::avx512) {
    exp_with_avx512(x.data(), y.data(), n);
    CHECK(max_rel(y.data()) < 3e-7);
    CHECK(max_rel(y.data() + n) < 3e-7);
    float extremes[16] = {-1e4f, -200.0f, -88.0f, -87.5f, 0.0f, -0.0f, 1e-30f, -INFINITY};
    float out[32];
    exp_with_avx512(extremes, out, 16);
    for (int i = 0; i < 4; ++i) CHECK((out[i] >= 0.0f && out[i] < 1.2e-38f));
    CHECK(out[4] == 1.0f);
    CHECK(out[7] == 0.0f);
    CHECK(out[16 + 7] == 0.0f);
  }
}

TEST_CASE("large logits stay finite and match the reference", "[attention][stability]") {
  const CsrGraph& g = graph_cases()[0].g;  // random, with isolated nodes
  const std::int64_t n = g.num_nodes, E = g.num_edges();
  for (Shape s : {Shape{8, 8}, Shape{3, 5}}) {
    const int H = s.H, F = s.F;
    std::mt19937 rng(99);
    Tensor z = random_tensor(n, H * F, rng, -30, 30);
    Tensor el = random_tensor(n, H, rng, -1000, 1000), er = random_tensor(n, H, rng, -1000, 1000);
    Tensor d_out = random_tensor(n, H * F, rng, -1, 1);
    // Reference from the float logits (rounding el + er at 1e3 moves exp by ~1e-4).
    const ref::DMat alpha_ref = ref::softmax(g, ref::logits_additive(g, ref::to_d(el), ref::to_d(er), 0.2));
    const ref::DMat out_ref = ref::aggregate(g, alpha_ref, ref::to_d(z));
    const ref::DMat dalpha_ref = ref::softmax(g, ref::logits_dot(g, ref::to_d(z), H, 1.0));
    Restore restore;
    for (cpu::SimdLevel lvl : levels()) {
      cpu::set_simd_level(lvl);
      INFO("simd=" << cpu::simd_level_name(lvl) << " H=" << H << " F=" << F);
      Tensor out = Tensor::zeros(n, H * F), alpha = Tensor::zeros(E, H);
      cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, out, alpha);
      CHECK(testutil::all_finite(out));
      CHECK(testutil::all_finite(alpha));
      CHECK(rel_err(alpha, alpha_ref) < 1e-2);
      CHECK(rel_err(out, out_ref) < 1e-2);
      Tensor a2 = Tensor::zeros(E, H);
      cpu::edge_softmax_additive_forward(g, el, er, 0.2f, a2);
      CHECK(testutil::all_finite(a2));
      CHECK(rel_err(a2, alpha_ref) < 1e-2);
      Tensor dz = Tensor::zeros(n, H * F), del = Tensor::zeros(n, H), der = Tensor::zeros(n, H);
      cpu::gat_fused_additive_backward(g, z, el, er, 0.2f, alpha, d_out, dz, del, der);
      CHECK(testutil::all_finite(dz));
      CHECK(testutil::all_finite(del));
      CHECK(testutil::all_finite(der));
      // Dot logits ~ |z|^2 F up to ~7e3 with scale 1.
      Tensor outd = Tensor::zeros(n, H * F), alphad = Tensor::zeros(E, H);
      cpu::gat_fused_dot_forward(g, z, H, 1.0f, outd, alphad);
      CHECK(testutil::all_finite(outd));
      CHECK(rel_err(alphad, dalpha_ref) < 1e-2);
      Tensor dzd = Tensor::zeros(n, H * F);
      cpu::gat_fused_dot_backward(g, z, H, 1.0f, alphad, d_out, dzd);
      CHECK(testutil::all_finite(dzd));
    }
  }
}

// gat_fused_additive_forward_rows (inference: rows handed to a sink in
// chunks, no attention weights kept for H = F = 8) against the training
// forward's rows: bitwise, every row exactly once, at every SIMD level, 1 and
// 2 threads, narrow and wide logits (the lazy rescale branch).
namespace {
struct RowsCollect {
  Tensor out;
  std::vector<int> seen;  // per row (each chunk's rows are written by one thread)
};
void collect_rows(void* ctx, std::int64_t r0, std::int64_t r1, const float* rows) {
  auto& c = *static_cast<RowsCollect*>(ctx);
  const std::int64_t w = c.out.cols();
  for (std::int64_t r = r0; r < r1; ++r) {
    std::copy(rows + (r - r0) * w, rows + (r - r0 + 1) * w, c.out.row(r));
    ++c.seen[std::size_t(r)];
  }
}
}  // namespace

TEST_CASE("gat_fused_additive_forward_rows gives gat_fused_additive_forward's rows bitwise", "[attention][fused]") {
  Restore restore;
  for (float spread : {3.f, 20.f})
    for_each_config([&](const GraphCase& gc, Shape s, bool strided, std::uint32_t seed) {
      const CsrGraph& g = gc.g;
      const std::int64_t n = g.num_nodes, E = g.num_edges();
      const int H = s.H, F = s.F;
      std::mt19937 rng(seed);
      Tensor z = random_tensor(n, H * F, rng, -1, 1, strided);
      Tensor el = random_tensor(n, H, rng, -spread, spread, strided),
             er = random_tensor(n, H, rng, -spread, spread, strided);
      for (cpu::SimdLevel lvl : levels())
        for (int nt : {1, 2}) {
          cpu::set_simd_level(lvl);
          omp_set_num_threads(nt);
          INFO(context(gc.name, s, strided) << " spread " << spread << " simd=" << cpu::simd_level_name(lvl)
                                            << " threads=" << nt);
          Tensor want = Tensor::zeros(n, H * F), a = Tensor::zeros(E, H);
          cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, want, a);
          RowsCollect c{Tensor::full(n, H * F, std::nanf("")), std::vector<int>(std::size_t(n), 0)};
          Tensor scratch = Tensor::zeros(E, H);
          cpu::gat_fused_additive_forward_rows(g, z, el, er, 0.2f, scratch, &collect_rows, &c);
          CHECK(testutil::bitwise_equal(c.out, want));
          CHECK(std::count(c.seen.begin(), c.seen.end(), 1) == n);
        }
    });
  const CsrGraph g = graph_cases()[0].g;
  CHECK_THROWS_WITH(cpu::gat_fused_additive_forward_rows(g, Tensor::zeros(g.num_nodes, 64), Tensor::zeros(g.num_nodes, 8),
                                                         Tensor::zeros(g.num_nodes, 8), 0.2f,
                                                         Tensor::zeros(g.num_edges(), 8), nullptr, nullptr),
                    Catch::Contains("gat_fused_additive_forward_rows: no sink"));
}

TEST_CASE("fused online softmax rescales exactly when logits spread widely", "[attention][fused][rescale]") {
  // Logits spanning tens of units move the running max by more than the lazy
  // rescale margin, so the rescale branch runs often; results must still match
  // the reference tightly (float rounding of logits ~30 costs ~1e-6 relative).
  for (int gi : {0, 2}) {  // random, hub
    const GraphCase& gc = graph_cases()[gi];
    const CsrGraph& g = gc.g;
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    for (Shape s : {Shape{8, 8}, Shape{3, 5}}) {
      const int H = s.H, F = s.F;
      std::mt19937 rng(42 + gi);
      Tensor z = random_tensor(n, H * F, rng, -2.5, 2.5);
      Tensor el = random_tensor(n, H, rng, -20, 20), er = random_tensor(n, H, rng, -20, 20);
      const ref::DMat alpha_ref = ref::softmax(g, ref::logits_additive(g, ref::to_d(el), ref::to_d(er), 0.5));
      const ref::DMat out_ref = ref::aggregate(g, alpha_ref, ref::to_d(z));
      const ref::DMat alphad_ref = ref::softmax(g, ref::logits_dot(g, ref::to_d(z), H, 1.0));
      const ref::DMat outd_ref = ref::aggregate(g, alphad_ref, ref::to_d(z));
      sweep(
          context(gc.name, s, false) + " wide logits",
          [&] {
            Tensor out = Tensor::zeros(n, H * F), a = Tensor::zeros(E, H);
            Tensor outd = Tensor::zeros(n, H * F), ad = Tensor::zeros(E, H);
            cpu::gat_fused_additive_forward(g, z, el, er, 0.5f, out, a);
            cpu::gat_fused_dot_forward(g, z, H, 1.0f, outd, ad);
            return std::vector<Tensor>{out, a, outd, ad};
          },
          [&](const std::vector<Tensor>& o) {
            CHECK_CLOSE(o[0], out_ref, 3e-5);
            CHECK_CLOSE(o[1], alpha_ref, 3e-5);
            CHECK_CLOSE(o[2], outd_ref, 3e-5);
            CHECK_CLOSE(o[3], alphad_ref, 3e-5);
          });
    }
  }
}

TEST_CASE("rows without edges give zero output and no NaN", "[attention][isolated]") {
  // Nodes 2 and 3 have no in-edges; node 3 has no edges at all.
  const CsrGraph g = testutil::graph_from_adjacency({{0, 1}, {0, 2}, {}, {}});
  Restore restore;
  for (cpu::SimdLevel lvl : levels()) {
    cpu::set_simd_level(lvl);
    for (Shape s : kShapes) {
      INFO("simd=" << cpu::simd_level_name(lvl) << " H=" << s.H << " F=" << s.F);
      std::mt19937 rng(5);
      Tensor z = random_tensor(4, s.H * s.F, rng), el = random_tensor(4, s.H, rng), er = random_tensor(4, s.H, rng);
      Tensor out = Tensor::full(4, s.H * s.F, 7.0f), alpha = Tensor::zeros(g.num_edges(), s.H);
      cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, out, alpha);
      for (std::int64_t c = 0; c < out.cols(); ++c) {
        CHECK(out.at(2, c) == 0.0f);
        CHECK(out.at(3, c) == 0.0f);
      }
      CHECK(testutil::all_finite(out));
      Tensor outd = Tensor::full(4, s.H * s.F, 7.0f);
      cpu::gat_fused_dot_forward(g, z, s.H, 0.5f, outd, alpha);
      CHECK(outd.at(3, 0) == 0.0f);
      CHECK(testutil::all_finite(outd));
      Tensor d_out = random_tensor(4, s.H * s.F, rng), dz = Tensor::zeros(4, s.H * s.F);
      Tensor del = Tensor::zeros(4, s.H), der = Tensor::zeros(4, s.H);
      cpu::gat_fused_additive_backward(g, z, el, er, 0.2f, alpha, d_out, dz, del, der);
      CHECK(testutil::all_finite(dz));
      CHECK(del.at(3, 0) == 0.0f);
      CHECK(der.at(3, 0) == 0.0f);
      CHECK(dz.at(3, 0) == 0.0f);
    }
  }
}

TEST_CASE("empty graph and empty edge set are fine", "[attention][edge]") {
  const CsrGraph empty = testutil::graph_from_adjacency({});
  Tensor z = Tensor::zeros(0, 16), el = Tensor::zeros(0, 2), alpha = Tensor::zeros(0, 2);
  CHECK_NOTHROW(cpu::gat_fused_additive_forward(empty, z, el, el, 0.2f, z, alpha));
  CHECK_NOTHROW(cpu::gat_fused_dot_backward(empty, z, 2, 1.0f, alpha, z, z));
  const CsrGraph no_edges = testutil::graph_from_adjacency({{}, {}, {}});
  std::mt19937 rng(1);
  Tensor z3 = random_tensor(3, 16, rng), el3 = random_tensor(3, 2, rng), out = Tensor::full(3, 16, 1.0f);
  cpu::gat_fused_additive_forward(no_edges, z3, el3, el3, 0.2f, out, alpha);
  CHECK(out.at(1, 5) == 0.0f);
}

// ---- bad arguments ----------------------------------------------------------------

TEST_CASE("attention kernels reject bad arguments with messages naming them", "[attention][errors]") {
  using Catch::Contains;
  const CsrGraph& g = graph_cases()[0].g;
  const std::int64_t n = g.num_nodes, E = g.num_edges();
  std::mt19937 rng(11);
  Tensor z = random_tensor(n, 64, rng), el = random_tensor(n, 8, rng), er = random_tensor(n, 8, rng);
  Tensor alpha = Tensor::zeros(E, 8), out = Tensor::zeros(n, 64);
  const std::string e_str = std::to_string(E);

  REQUIRE_THROWS_AS(cpu::aggregate_forward(g, Tensor::zeros(E - 1, 8), z, out), gatcore::InvalidArgument);
  REQUIRE_THROWS_WITH(cpu::aggregate_forward(g, Tensor::zeros(E - 1, 8), z, out),
                      Contains("aggregate_forward: alpha: expected shape [E=" + e_str + ", H]"));
  REQUIRE_THROWS_WITH(cpu::aggregate_forward(g, Tensor::zeros(E, 3), z, out),
                      Contains("aggregate_forward: z: expected shape"));
  REQUIRE_THROWS_WITH(cpu::aggregate_forward(g, alpha, z, Tensor::zeros(n, 32)),
                      Contains("aggregate_forward: out: expected shape [n=" + std::to_string(n) + ", H*F=64], got [" +
                               std::to_string(n) + ", 32]"));
  REQUIRE_THROWS_WITH(cpu::aggregate_backward(g, alpha, z, out, Tensor::zeros(E, 4), Tensor{}),
                      Contains("aggregate_backward: d_alpha: expected shape [E=" + e_str + ", H=8], got [" + e_str +
                               ", 4]"));
  REQUIRE_THROWS_WITH(cpu::aggregate_backward(g, alpha, z, Tensor{}, Tensor{}, out),
                      Contains("aggregate_backward: d_out: tensor is undefined"));
  REQUIRE_THROWS_WITH(cpu::aggregate_forward(g, alpha, Tensor::zeros(n, 64, gatcore::DType::i32), out),
                      Contains("aggregate_forward: z: expected float32"));

  REQUIRE_THROWS_WITH(cpu::edge_softmax_additive_forward(g, el, Tensor::zeros(n, 4), 0.2f, alpha),
                      Contains("edge_softmax_additive_forward: er: expected shape"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_additive_forward(g, el, er, 0.2f, Tensor::zeros(E, 4)),
                      Contains("edge_softmax_additive_forward: alpha: expected shape [E=" + e_str + ", H=8], got [" +
                               e_str + ", 4]"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_additive_backward(g, el, er, 0.2f, alpha, Tensor::zeros(E, 2), el, er),
                      Contains("edge_softmax_additive_backward: d_alpha"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_additive_backward(g, el, er, 0.2f, alpha, alpha, Tensor::zeros(n, 2), er),
                      Contains("edge_softmax_additive_backward: d_el"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_dot_forward(g, z, 7, 1.0f, alpha), Contains("edge_softmax_dot_forward: h"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_dot_forward(g, z, 0, 1.0f, alpha),
                      Contains("edge_softmax_dot_forward: heads"));
  REQUIRE_THROWS_WITH(cpu::edge_softmax_dot_backward(g, z, 8, 1.0f, alpha, alpha, Tensor::zeros(n, 63)),
                      Contains("edge_softmax_dot_backward: d_h"));

  REQUIRE_THROWS_WITH(cpu::gat_fused_additive_forward(g, Tensor::zeros(n + 1, 64), el, er, 0.2f, out, alpha),
                      Contains("gat_fused_additive_forward: z: expected shape [n=" + std::to_string(n)));
  REQUIRE_THROWS_WITH(cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, out, Tensor::zeros(E + 1, 8)),
                      Contains("gat_fused_additive_forward: alpha"));
  REQUIRE_THROWS_WITH(cpu::gat_fused_additive_backward(g, z, el, er, 0.2f, alpha, out, out, el, Tensor::zeros(n, 1)),
                      Contains("gat_fused_additive_backward: d_er"));
  REQUIRE_THROWS_WITH(cpu::gat_fused_dot_forward(g, z, 8, 1.0f, Tensor::zeros(n, 8), alpha),
                      Contains("gat_fused_dot_forward: out"));
  REQUIRE_THROWS_WITH(cpu::gat_fused_dot_backward(g, z, 8, 1.0f, alpha, Tensor::zeros(2, 64), out),
                      Contains("gat_fused_dot_backward: d_out"));

  Tensor al = Tensor::zeros(8, 8);
  REQUIRE_THROWS_WITH(cpu::attention_projection_forward(z, al, Tensor::zeros(8, 4), el, er),
                      Contains("attention_projection_forward: a_r: expected shape [H=8, F=8], got [8, 4]"));
  REQUIRE_THROWS_WITH(cpu::attention_projection_forward(Tensor::zeros(n, 60), al, al, el, er),
                      Contains("attention_projection_forward: z"));
  REQUIRE_THROWS_WITH(cpu::attention_projection_backward(z, al, al, el, er, out, Tensor::zeros(4, 8), Tensor{}),
                      Contains("attention_projection_backward: d_al"));

  // A graph whose transpose was never built.
  CsrGraph broken = g;
  broken.out_ptr.clear();
  REQUIRE_THROWS_WITH(cpu::aggregate_forward(broken, alpha, z, out), Contains("aggregate_forward: graph: transpose"));
  broken = g;
  broken.indptr.pop_back();
  REQUIRE_THROWS_WITH(cpu::gat_fused_dot_forward(broken, z, 8, 1.0f, out, alpha),
                      Contains("gat_fused_dot_forward: graph: indptr"));
}
