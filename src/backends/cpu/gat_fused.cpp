// Fused graph attention: logits + online softmax + aggregation in one pass per
// destination row, storing only alpha [E, H]; backward recomputes d_alpha per
// row and gathers the source-side terms through the transpose. Generic path
// for any H, F plus an H = 8, F = 8 register path, each for scalar / AVX2 /
// AVX-512 (see attn_simd.hpp).
#include "src/backends/cpu/gat_fused.hpp"

#include "src/backends/cpu/attn_simd.hpp"

namespace gatcore::cpu::attn {
// Lazy online softmax: the reference max moves only when a logit exceeds it by
// more than this (weights stay <= e^16 ~ 9e6, far from float overflow).
inline constexpr float kRescaleMargin = 16.0f;
struct FusedArgs {
  GraphView g;
  int H = 0, F = 0;
  float slope = 0.0f, scale = 0.0f;
  Mat z, el, er, out, alpha, d_out, d_z, d_el, d_er;
  float* S = nullptr;  // E x H scratch: d_alpha, then the logit gradient
};
}  // namespace gatcore::cpu::attn

#define ATTN_IMPL "src/backends/cpu/attn_fused_impl.inc"
#include "src/backends/cpu/attn_instantiate.inc"

namespace gatcore::cpu {
using namespace attn;

namespace {
FusedArgs additive_args(const char* fn, const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                        const Tensor& alpha) {
  FusedArgs a;
  a.g = graph_view(fn, g);
  check_arg(fn, "el", el, {"n", a.g.n}, {"H", -1});
  GATCORE_CHECK(el.cols() >= 1, fn, ": el: expected shape [n=", a.g.n, ", H] with H >= 1, got ", el.shape_str());
  a.H = static_cast<int>(el.cols());
  check_arg(fn, "er", er, {"n", a.g.n}, {"H", a.H});
  check_arg(fn, "z", z, {"n", a.g.n}, {"H*F", -1});
  GATCORE_CHECK(z.cols() % a.H == 0, fn, ": z: expected shape [n=", a.g.n, ", H*F] with H=", a.H,
                " (the columns of el), got ", z.shape_str());
  a.F = static_cast<int>(z.cols() / a.H);
  check_arg(fn, "alpha", alpha, {"E", a.g.E}, {"H", a.H});
  a.z = mat(z);
  a.el = mat(el);
  a.er = mat(er);
  a.alpha = mat(alpha);
  return a;
}

FusedArgs dot_args(const char* fn, const CsrGraph& g, const Tensor& z, int heads, const Tensor& alpha) {
  FusedArgs a;
  a.g = graph_view(fn, g);
  GATCORE_CHECK(heads >= 1, fn, ": heads: expected >= 1, got ", heads);
  check_arg(fn, "z", z, {"n", a.g.n}, {"H*F", -1});
  GATCORE_CHECK(z.cols() % heads == 0, fn, ": z: expected shape [n=", a.g.n, ", H*F] with H=heads=", heads,
                ", got ", z.shape_str(), " (columns not a multiple of heads)");
  a.H = heads;
  a.F = static_cast<int>(z.cols() / heads);
  check_arg(fn, "alpha", alpha, {"E", a.g.E}, {"H", a.H});
  a.z = mat(z);
  a.alpha = mat(alpha);
  return a;
}
}  // namespace

void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                float slope, const Tensor& out, const Tensor& alpha) {
  static const char* fn = "gat_fused_additive_forward";
  FusedArgs a = additive_args(fn, g, z, el, er, alpha);
  check_arg(fn, "out", out, {"n", a.g.n}, {"H*F", z.cols()});
  a.out = mat(out);
  a.slope = slope;
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, fused_add_fwd);
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f(a, b, e); });
}

void gat_fused_additive_forward_rows(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                     float slope, const Tensor& alpha, AttentionRowsSink sink, void* ctx) {
  static const char* fn = "gat_fused_additive_forward_rows";
  GATCORE_CHECK(sink, fn, ": no sink");
  FusedArgs a = additive_args(fn, g, z, el, er, alpha);
  a.slope = slope;
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, fused_add_fwd_rows);
  // 32 rows of 64 floats: 8 KiB, the chunk stays in L1 for the sink.
  constexpr std::int64_t kChunk = 32;
  const std::int64_t w = z.cols();
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) {
    float* buf = scratch(static_cast<std::size_t>(kChunk * w), 3);
    for (std::int64_t c0 = b; c0 < e; c0 += kChunk) {
      const std::int64_t c1 = std::min(e, c0 + kChunk);
      f(a, c0, c1, buf);
      sink(ctx, c0, c1, buf);
    }
  });
}

void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& out,
                           const Tensor& alpha) {
  static const char* fn = "gat_fused_dot_forward";
  FusedArgs a = dot_args(fn, g, z, heads, alpha);
  check_arg(fn, "out", out, {"n", a.g.n}, {"H*F", z.cols()});
  a.out = mat(out);
  a.scale = scale;
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, fused_dot_fwd);
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f(a, b, e); });
}

void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                 float slope, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z,
                                 const Tensor& d_el, const Tensor& d_er) {
  static const char* fn = "gat_fused_additive_backward";
  FusedArgs a = additive_args(fn, g, z, el, er, alpha);
  a.slope = slope;
  check_arg(fn, "d_out", d_out, {"n", a.g.n}, {"H*F", z.cols()});
  const bool want_z = check_opt(fn, "d_z", d_z, {"n", a.g.n}, {"H*F", z.cols()});
  const bool want_el = check_opt(fn, "d_el", d_el, {"n", a.g.n}, {"H", a.H});
  const bool want_er = check_opt(fn, "d_er", d_er, {"n", a.g.n}, {"H", a.H});
  a.d_out = mat(d_out);
  a.d_z = mat(d_z);
  a.d_el = mat(d_el);
  a.d_er = mat(d_er);
  const bool fixed = a.H == 8 && a.F == 8;
  const auto f2 = ATTN_SELECT(fixed, fused_add_bwd_src);
  if (want_el || want_er) {
    a.S = scratch(static_cast<std::size_t>(a.g.E) * a.H, 0);
    const auto f1 = ATTN_SELECT(fixed, fused_add_bwd);
    if (want_z || want_er)
      parallel_two_phase(
          a.g, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); },
          [&](std::int64_t b, std::int64_t e) { f2(a, b, e); });
    else
      parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); });
  } else if (want_z) {
    parallel_rows(a.g, a.g.out_ptr, [&](std::int64_t b, std::int64_t e) { f2(a, b, e); });
  }
}

void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& alpha,
                            const Tensor& d_out, const Tensor& d_z) {
  static const char* fn = "gat_fused_dot_backward";
  FusedArgs a = dot_args(fn, g, z, heads, alpha);
  a.scale = scale;
  check_arg(fn, "d_out", d_out, {"n", a.g.n}, {"H*F", z.cols()});
  if (!check_opt(fn, "d_z", d_z, {"n", a.g.n}, {"H*F", z.cols()})) return;
  a.d_out = mat(d_out);
  a.d_z = mat(d_z);
  a.S = scratch(static_cast<std::size_t>(a.g.E) * a.H, 0);
  const bool fixed = a.H == 8 && a.F == 8;
  const auto f1 = ATTN_SELECT(fixed, fused_dot_bwd);
  const auto f2 = ATTN_SELECT(fixed, fused_dot_bwd_src);
  parallel_two_phase(
      a.g, [&](std::int64_t b, std::int64_t e) { f1(a, b, e); }, [&](std::int64_t b, std::int64_t e) { f2(a, b, e); });
}

}  // namespace gatcore::cpu
