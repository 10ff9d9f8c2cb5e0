// Multi-head aggregation (SpMM with per-edge, per-head weights) and its
// backward. Generic path for any H, F plus an H = 8, F = 8 register path, each
// for scalar / AVX2 / AVX-512 (see attn_simd.hpp).
#include "src/backends/cpu/aggregation.hpp"

#include "src/backends/cpu/attn_simd.hpp"

namespace gatcore::cpu::attn {
struct AggArgs {
  GraphView g;
  int H = 0, F = 0;
  Mat alpha, z, out, d_out, d_alpha, d_z;
};
}  // namespace gatcore::cpu::attn

#define ATTN_IMPL "src/backends/cpu/attn_aggregation_impl.inc"
#include "src/backends/cpu/attn_instantiate.inc"

namespace gatcore::cpu {
using namespace attn;

namespace {
// Shapes shared by forward and backward: alpha [E, H], z [n, H*F].
AggArgs agg_args(const char* fn, const CsrGraph& g, const Tensor& alpha, const Tensor& z) {
  AggArgs a;
  a.g = graph_view(fn, g);
  check_arg(fn, "alpha", alpha, {"E", a.g.E}, {"H", -1});
  GATCORE_CHECK(alpha.cols() >= 1, fn, ": alpha: expected shape [E=", a.g.E, ", H] with H >= 1, got ",
                alpha.shape_str());
  check_arg(fn, "z", z, {"n", a.g.n}, {"H*F", -1});
  GATCORE_CHECK(z.cols() % alpha.cols() == 0, fn, ": z: expected shape [n=", a.g.n, ", H*F] with H=",
                alpha.cols(), " (the columns of alpha), got ", z.shape_str());
  a.H = static_cast<int>(alpha.cols());
  a.F = static_cast<int>(z.cols() / alpha.cols());
  a.alpha = mat(alpha);
  a.z = mat(z);
  return a;
}
}  // namespace

void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out) {
  static const char* fn = "aggregate_forward";
  AggArgs a = agg_args(fn, g, alpha, z);
  check_arg(fn, "out", out, {"n", a.g.n}, {"H*F", z.cols()});
  a.out = mat(out);
  const bool fixed = a.H == 8 && a.F == 8;
  const auto f = ATTN_SELECT(fixed, agg_fwd);
  parallel_rows(a.g, a.g.indptr, [&](std::int64_t b, std::int64_t e) { f(a, b, e); });
}

void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out,
                        const Tensor& d_alpha, const Tensor& d_z) {
  static const char* fn = "aggregate_backward";
  AggArgs a = agg_args(fn, g, alpha, z);
  check_arg(fn, "d_out", d_out, {"n", a.g.n}, {"H*F", z.cols()});
  const bool want_alpha = check_opt(fn, "d_alpha", d_alpha, {"E", a.g.E}, {"H", a.H});
  const bool want_z = check_opt(fn, "d_z", d_z, {"n", a.g.n}, {"H*F", z.cols()});
  if (!want_alpha && !want_z) return;
  a.d_out = mat(d_out);
  a.d_alpha = mat(d_alpha);
  a.d_z = mat(d_z);
  const bool fixed = a.H == 8 && a.F == 8;
  const auto fa = ATTN_SELECT(fixed, agg_bwd_alpha);
  const auto fz = ATTN_SELECT(fixed, agg_bwd_z);
  // The two halves write disjoint outputs: no barrier between them.
  const std::span<const std::int64_t> p1(a.g.indptr, static_cast<std::size_t>(a.g.n + 1));
  const std::span<const std::int64_t> p2(a.g.out_ptr, static_cast<std::size_t>(a.g.n + 1));
#pragma omp parallel if (a.g.E + a.g.n >= kParallelMin)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    if (want_alpha) {
      const RowRange r = balanced_rows(p1, t, nt);
      if (r.begin < r.end) fa(a, r.begin, r.end);
    }
    if (want_z) {
      const RowRange r = balanced_rows(p2, t, nt);
      if (r.begin < r.end) fz(a, r.begin, r.end);
    }
  }
}

}  // namespace gatcore::cpu
