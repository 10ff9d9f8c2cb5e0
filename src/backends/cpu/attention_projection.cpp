// Additive attention projection el = <a_l, z^k>, er = <a_r, z^k> per head and
// its backward. Generic path for any H, F plus an H = 8, F = 8 register path,
// each for scalar / AVX2 / AVX-512 (see attn_simd.hpp).
#include "src/backends/cpu/attention_projection.hpp"

#include "src/backends/cpu/attn_simd.hpp"

namespace gatcore::cpu::attn {
inline constexpr std::int64_t kProjBlock = 256;
struct ProjArgs {
  std::int64_t n = 0;
  int H = 0, F = 0;
  Mat z, el, er, d_el, d_er, d_z;
  const float* al = nullptr;  // a_l packed to H*F contiguous floats
  const float* ar = nullptr;
  float* P = nullptr;  // per-block partials of (d_al, d_ar): nblocks x 2HF
};
}  // namespace gatcore::cpu::attn

#define ATTN_IMPL "src/backends/cpu/attn_projection_impl.inc"
#include "src/backends/cpu/attn_instantiate.inc"

namespace gatcore::cpu {
using namespace attn;

namespace {
// Checks z, a_l, a_r and packs a_l / a_r contiguously (they may be strided).
ProjArgs proj_args(const char* fn, const Tensor& z, const Tensor& a_l, const Tensor& a_r) {
  ProjArgs a;
  check_arg(fn, "a_l", a_l, {"H", -1}, {"F", -1});
  GATCORE_CHECK(a_l.rows() >= 1, fn, ": a_l: expected shape [H, F] with H >= 1, got ", a_l.shape_str());
  a.H = static_cast<int>(a_l.rows());
  a.F = static_cast<int>(a_l.cols());
  check_arg(fn, "a_r", a_r, {"H", a.H}, {"F", a.F});
  check_arg(fn, "z", z, {"n", -1}, {"H*F", std::int64_t(a.H) * a.F});
  a.n = z.rows();
  a.z = mat(z);
  const std::size_t hf = static_cast<std::size_t>(a.H) * a.F;
  float* pack = scratch(2 * hf, 1);
  for (int k = 0; k < a.H; ++k)
    for (int f = 0; f < a.F; ++f) {
      pack[k * a.F + f] = a_l.row(k)[f];
      pack[hf + k * a.F + f] = a_r.row(k)[f];
    }
  a.al = pack;
  a.ar = pack + hf;
  return a;
}
}  // namespace

void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                  const Tensor& er) {
  static const char* fn = "attention_projection_forward";
  ProjArgs a = proj_args(fn, z, a_l, a_r);
  check_arg(fn, "el", el, {"n", a.n}, {"H", a.H});
  check_arg(fn, "er", er, {"n", a.n}, {"H", a.H});
  a.el = mat(el);
  a.er = mat(er);
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, proj_fwd);
  const std::int64_t nb = (a.n + kProjBlock - 1) / kProjBlock;
  parallel_blocks(nb, a.n * a.H, [&](std::int64_t b) { f(a, b); });
}

void attention_projection_forward_rows(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                       const Tensor& er, std::int64_t r0, std::int64_t r1) {
  static const char* fn = "attention_projection_forward_rows";
  ProjArgs a = proj_args(fn, z, a_l, a_r);
  check_arg(fn, "el", el, {"n", a.n}, {"H", a.H});
  check_arg(fn, "er", er, {"n", a.n}, {"H", a.H});
  GATCORE_CHECK(0 <= r0 && r0 <= r1 && r1 <= a.n, fn, ": rows [", r0, ", ", r1, ") outside [0, ", a.n, ")");
  a.el = mat(el);
  a.er = mat(er);
  ATTN_SELECT(a.H == 8 && a.F == 8, proj_fwd_rows)(a, r0, r1);
}

void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& d_el,
                                   const Tensor& d_er, const Tensor& d_z, const Tensor& d_al, const Tensor& d_ar) {
  static const char* fn = "attention_projection_backward";
  ProjArgs a = proj_args(fn, z, a_l, a_r);
  check_arg(fn, "d_el", d_el, {"n", a.n}, {"H", a.H});
  check_arg(fn, "d_er", d_er, {"n", a.n}, {"H", a.H});
  const bool want_z = check_opt(fn, "d_z", d_z, {"n", a.n}, {"H*F", std::int64_t(a.H) * a.F});
  const bool want_al = check_opt(fn, "d_al", d_al, {"H", a.H}, {"F", a.F});
  const bool want_ar = check_opt(fn, "d_ar", d_ar, {"H", a.H}, {"F", a.F});
  if (!want_z && !want_al && !want_ar) return;
  a.d_el = mat(d_el);
  a.d_er = mat(d_er);
  a.d_z = mat(d_z);
  const std::int64_t hf = std::int64_t(a.H) * a.F;
  const std::int64_t nb = (a.n + kProjBlock - 1) / kProjBlock;
  if (want_al || want_ar) a.P = scratch(static_cast<std::size_t>(nb * 2 * hf), 2);
  const auto f = ATTN_SELECT(a.H == 8 && a.F == 8, proj_bwd);
  parallel_blocks(nb, a.n * a.H, [&](std::int64_t b) { f(a, b); });
  if (!a.P) return;
  // Block partials summed in block order (independent of the thread count).
  for (int side = 0; side < 2; ++side) {
    const Tensor& out = side == 0 ? d_al : d_ar;
    if (!out.defined()) continue;
    for (int k = 0; k < a.H; ++k) {
      float* o = out.row(k);
      for (int f0 = 0; f0 < a.F; ++f0) {
        const std::int64_t c = side * hf + k * a.F + f0;
        float sum = 0.0f;
        for (std::int64_t b = 0; b < nb; ++b) sum += a.P[b * 2 * hf + c];
        o[f0] += sum;
      }
    }
  }
}

}  // namespace gatcore::cpu
