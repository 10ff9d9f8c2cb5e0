// Per-head edge softmax (additive and dot-product logits) and its backward.
// Generic path for any H, F plus an H = 8 register path (additive: any F;
// dot: F = 8), each for scalar / AVX2 / AVX-512 (see attn_simd.hpp).
#include "src/backends/cpu/edge_softmax.hpp"

#include "src/backends/cpu/attn_simd.hpp"

namespace gatcore::cpu::attn {
struct SmArgs {
  GraphView g;
  int H = 0, F = 0;
  float slope = 0.0f, scale = 0.0f;
  Mat el, er, h, alpha, d_alpha, d_el, d_er, d_h;
  float* S = nullptr;  // E x H scratch (per-edge logit gradient)
};
}  // namespace gatcore::cpu::attn

#define ATTN_IMPL "src/backends/cpu/attn_softmax_impl.inc"
#include "src/backends/cpu/attn_instantiate.inc"

namespace gatcore::cpu {
using namespace attn;

namespace {
SmArgs additive_args(const char* fn, const CsrGraph& g, const Tensor& el, const Tensor& er, const Tensor& alpha) {
  SmArgs a;
  a.g = graph_view(fn, g);
  check_arg(fn, "el", el, {"n", a.g.n}, {"H", -1});
  GATCORE_CHECK(el.cols() >= 1, fn, ": el: expected shape [n=", a.g.n, ", H] with H >= 1, got ", el.shape_str());
  a.H = static_cast<int>(el.cols());
  check_arg(fn, "er", er, {"n", a.g.n}, {"H", a.H});
  check_arg(fn, "alpha", alpha, {"E", a.g.E}, {"H", a.H});
  a.el = mat(el);
  a.er = mat(er);
  a.alpha = mat(alpha);
  return a;
}

SmArgs dot_args(const char* fn, const CsrGraph& g, const Tensor& h, int heads, const Tensor& alpha) {
  SmArgs a;
  a.g = graph_view(fn, g);
  GATCORE_CHECK(heads >= 1, fn, ": heads: expected >= 1, got ", heads);
  check_arg(fn, "h", h, {"n", a.g.n}, {"H*F", -1});
  GATCORE_CHECK(h.cols() % heads == 0, fn, ": h: expected shape [n=", a.g.n, ", H*F] with H=heads=", heads,
                ", got ", h.shape_str(), " (columns not a multiple of heads)");
  a.H = heads;
  a.F = static_cast<int>(h.cols() / heads);
  check_arg(fn, "alpha", alpha, {"E", a.g.E}, {"H", a.H});
  a.h = mat(h);
  a.alpha = mat(alpha);
  return a;
}
}  // namespace

void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                   const Tensor& alpha) {
  SmArgs a = additive_args("edge_softmax_additive_forward", g, el, er, alpha);
  a.slope = slope;
  const auto f = ATTN_SELECT(a.H == 8, sm_add_fwd);
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f(a, b, e); });
}

void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha) {
  SmArgs a = dot_args("edge_softmax_dot_forward", g, h, heads, alpha);
  a.scale = scale;
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, sm_dot_fwd);
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f(a, b, e); });
}

void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                    const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el,
                                    const Tensor& d_er) {
  static const char* fn = "edge_softmax_additive_backward";
  SmArgs a = additive_args(fn, g, el, er, alpha);
  a.slope = slope;
  check_arg(fn, "d_alpha", d_alpha, {"E", a.g.E}, {"H", a.H});
  const bool want_el = check_opt(fn, "d_el", d_el, {"n", a.g.n}, {"H", a.H});
  const bool want_er = check_opt(fn, "d_er", d_er, {"n", a.g.n}, {"H", a.H});
  if (!want_el && !want_er) return;
  a.d_alpha = mat(d_alpha);
  a.d_el = mat(d_el);
  a.d_er = mat(d_er);
  const bool fixed = a.H == 8;
  const auto f1 = ATTN_SELECT(fixed, sm_add_bwd);
  if (want_er) {
    a.S = scratch(static_cast<std::size_t>(a.g.E) * a.H, 0);
    const auto f2 = ATTN_SELECT(fixed, sm_add_bwd_src);
    parallel_two_phase(
        a.g, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); }, [&](std::int64_t b, std::int64_t e) { f2(a, b, e); });
  } else {
    parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); });
  }
}

void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha,
                               const Tensor& d_alpha, const Tensor& d_h) {
  static const char* fn = "edge_softmax_dot_backward";
  SmArgs a = dot_args(fn, g, h, heads, alpha);
  a.scale = scale;
  check_arg(fn, "d_alpha", d_alpha, {"E", a.g.E}, {"H", a.H});
  if (!check_opt(fn, "d_h", d_h, {"n", a.g.n}, {"H*F", h.cols()})) return;
  a.d_alpha = mat(d_alpha);
  a.d_h = mat(d_h);
  a.S = scratch(static_cast<std::size_t>(a.g.E) * a.H, 0);
  const bool fixed = a.H == 8 && a.F == 8;
  const auto f1 = ATTN_SELECT(fixed, sm_dot_bwd);
  const auto f2 = ATTN_SELECT(fixed, sm_dot_bwd_src);
  parallel_two_phase(
      a.g, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); }, [&](std::int64_t b, std::int64_t e) { f2(a, b, e); });
}

}  // namespace gatcore::cpu
