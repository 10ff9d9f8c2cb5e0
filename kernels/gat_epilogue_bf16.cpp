// gat_epilogue_bf16.hpp: one AVX-512 pass per row, 32 columns (16 pair words) at a time.
#include "kernels/gat_epilogue_bf16.hpp"

#include <algorithm>

#include "gatcore/precision.hpp"
#include "kernels/fast_math.hpp"
#include "kernels/gat_fused.hpp"
#include "kernels/nn_detail.hpp"
#include "kernels/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
GATCORE_TARGET_BEGIN("avx512f,avx512bw,avx512vl,avx512dq,avx512bf16,avx2,fma")
namespace gatcore::cpu {
namespace {

inline __mmask16 lanes(std::int64_t rem) {
  return rem >= 16 ? __mmask16(0xFFFF) : rem <= 0 ? __mmask16(0) : __mmask16((1u << rem) - 1u);
}

// 16 columns from c of [att | self] (att kf wide): + bias on the self
// columns, tanhshrink, the affine map. Masked loads read only their lanes
// (no fault for the pointers before self / bias that c - kf < 0 gives).
inline __m512 epilogue16(const float* att, const float* self, std::int64_t c, std::int64_t W, std::int64_t kf,
                         const float* bias, const float* m, const float* s, const float* b) {
  const __mmask16 in = lanes(W - c);
  const __mmask16 sm = in & ~lanes(kf - c);  // the self-stream lanes
  __m512 v = _mm512_maskz_loadu_ps(in & ~sm, att + c);
  if (sm) {
    v = _mm512_mask_loadu_ps(v, sm, self + (c - kf));
    // add_row_bias on the self columns.
    if (bias) v = _mm512_mask_add_ps(v, sm, v, _mm512_maskz_loadu_ps(sm, bias + (c - kf)));
  }
  v = _mm512_sub_ps(v, fastmath::tanh_avx512(v));  // tanhshrink (activation_forward's tanh_mode_avx512)
  if (m)  // batchnorm_affine_forward: ((x - mean) - 0) * scale + shift, contracted to one FMA as compiled there
    v = _mm512_fmadd_ps(_mm512_sub_ps(v, _mm512_maskz_loadu_ps(in, m + c)), _mm512_maskz_loadu_ps(in, s + c),
                        _mm512_maskz_loadu_ps(in, b + c));
  return v;
}

// Operands of the epilogue, as raw pointers (Tensor::row is out of line: a
// call per row and block showed in profiles).
struct Epi {
  std::int64_t kf = 0, W = 0, lds = 0, ld = 0;
  const float* self = nullptr;  // row 0 of the self stream (null: none)
  const float *bias = nullptr, *m = nullptr, *s = nullptr, *b = nullptr;
  std::uint32_t* dst = nullptr;  // row 0
};

// Row r, its attention columns at a (any width).
inline void epilogue_row(const Epi& e, const float* a, std::int64_t r) {
  const float* sr = e.self ? e.self + r * e.lds : nullptr;
  std::uint32_t* d = e.dst + r * e.ld;
  for (std::int64_t c = 0; c < e.W; c += 32) {
    const __m512 lo = epilogue16(a, sr, c, e.W, e.kf, e.bias, e.m, e.s, e.b);
    const __m512 hi = epilogue16(a, sr, c + 16, e.W, e.kf, e.bias, e.m, e.s, e.b);
    // Zeroed lanes past W give a zero high half for an odd W (bf16_pairs' layout).
    _mm512_mask_storeu_epi32(d + c / 2, lanes((e.W - c + 1) / 2), (__m512i)_mm512_cvtne2ps_pbh(hi, lo));
  }
}

// Rows [r0, r1) of a block at most 16 NV columns wide (the paper's 72: NV =
// 5), row r's attention columns at att + (r - r0) lda. epilogue16's
// arithmetic, with what is the same for every row (lane masks, bias, the
// affine map's vectors) set up once per call instead of per row and vector,
// and no vector past W (per row and vector, that setup and the masked-out
// 6th vector of a 72-wide row cost more than the tanh).
template <int NV>
void epilogue_rows_nv(const Epi& e, const float* att, std::int64_t lda, std::int64_t r0, std::int64_t r1) {
  __mmask16 am[NV], sm[NV];
  __m512 bias[NV], mv[NV], sv[NV], bv[NV];
  for (int v = 0; v < NV; ++v) {
    const std::int64_t c = 16 * v;
    const __mmask16 in = lanes(e.W - c);
    sm[v] = in & ~lanes(e.kf - c);
    am[v] = in & ~sm[v];
    bias[v] = e.bias && sm[v] ? _mm512_maskz_loadu_ps(sm[v], e.bias + (c - e.kf)) : _mm512_setzero_ps();
    mv[v] = e.m ? _mm512_maskz_loadu_ps(in, e.m + c) : _mm512_setzero_ps();
    sv[v] = e.m ? _mm512_maskz_loadu_ps(in, e.s + c) : _mm512_setzero_ps();
    bv[v] = e.m ? _mm512_maskz_loadu_ps(in, e.b + c) : _mm512_setzero_ps();
  }
  for (std::int64_t r = r0; r < r1; ++r) {
    const float* a = att + (r - r0) * lda;
    const float* sr = e.self ? e.self + r * e.lds : nullptr;
    std::uint32_t* d = e.dst + r * e.ld;
    __m512 y[NV];
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) {
      __m512 x = _mm512_maskz_loadu_ps(am[v], a + 16 * v);
      if (sm[v]) {
        x = _mm512_mask_loadu_ps(x, sm[v], sr + (16 * v - e.kf));
        if (e.bias) x = _mm512_mask_add_ps(x, sm[v], x, bias[v]);
      }
      x = _mm512_sub_ps(x, fastmath::tanh_avx512(x));
      if (e.m) x = _mm512_fmadd_ps(_mm512_sub_ps(x, mv[v]), sv[v], bv[v]);
      y[v] = x;
    }
#pragma GCC unroll 8
    for (int v = 0; v < NV; v += 2) {
      const __mmask16 words = lanes((e.W - 16 * v + 1) / 2);
      if (v + 1 < NV)
        _mm512_mask_storeu_epi32(d + 8 * v, words, (__m512i)_mm512_cvtne2ps_pbh(y[v + 1], y[v]));
      else  // the same rounding, one vector
        _mm256_mask_storeu_epi32(d + 8 * v, __mmask8(words), (__m256i)_mm512_cvtneps_pbh(y[v]));
    }
  }
}

void epilogue_rows(const Epi& e, const float* att, std::int64_t lda, std::int64_t r0, std::int64_t r1) {
  switch ((e.W + 15) / 16) {
    case 1: epilogue_rows_nv<1>(e, att, lda, r0, r1); return;
    case 2: epilogue_rows_nv<2>(e, att, lda, r0, r1); return;
    case 3: epilogue_rows_nv<3>(e, att, lda, r0, r1); return;
    case 4: epilogue_rows_nv<4>(e, att, lda, r0, r1); return;
    case 5: epilogue_rows_nv<5>(e, att, lda, r0, r1); return;
    default:
      for (std::int64_t r = r0; r < r1; ++r) epilogue_row(e, att + (r - r0) * lda, r);
  }
}

// Argument names of an entry point's messages (literals: no string is built unless a check fails).
struct Names {
  const char *fn, *self, *self_b, *mean, *scale, *shift;
};
#define GATCORE_EPI_NAMES(fn) Names{fn, fn ": self", fn ": self_b", fn ": mean", fn ": scale", fn ": shift"}

// Checks shared by both entry points; n rows, kf attention columns.
Epi epilogue_args(const Names& nm, std::int64_t n, std::int64_t kf, const Tensor& self, const Tensor& self_b,
                  const Tensor& mean, const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  const char* fn = nm.fn;
  GATCORE_CHECK(bf16_supported(), fn, ": needs a CPU with AVX512_BF16");
  const std::int64_t S = self.defined() ? self.cols() : 0, W = kf + S;
  if (self.defined()) detail::check_arg(self, n, S, nm.self);
  GATCORE_CHECK(ld >= (W + 1) / 2, fn, ": ld ", ld, " below ", (W + 1) / 2, " words");
  GATCORE_CHECK(dst || n == 0, fn, ": no destination");
  if (self_b.defined()) detail::check_arg(self_b, 1, S, nm.self_b);
  Epi e;
  e.kf = kf;
  e.W = W;
  e.ld = ld;
  e.dst = dst;
  if (S > 0) {
    e.self = self.data();
    e.lds = self.ld();
  }
  e.bias = self_b.defined() && S > 0 ? self_b.data() : nullptr;
  if (mean.defined()) {
    detail::check_arg(mean, 1, W, nm.mean);
    detail::check_arg(scale, 1, W, nm.scale);
    detail::check_arg(shift, 1, W, nm.shift);
    e.m = mean.data();
    e.s = scale.data();
    e.b = shift.data();
  }
  return e;
}

void epilogue_rows_sink(void* ctx, std::int64_t r0, std::int64_t r1, const float* rows) {
  const Epi& e = *static_cast<const Epi*>(ctx);
  epilogue_rows(e, rows, e.kf, r0, r1);
}

}  // namespace

void gat_epilogue_bf16(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                       const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  check_cpu_f32(att, "gat_epilogue_bf16: att");
  const Epi e = epilogue_args(GATCORE_EPI_NAMES("gat_epilogue_bf16"), att.rows(), att.cols(), self, self_b, mean, scale, shift, dst, ld);
  const float* ab = att.data();
  const std::int64_t lda = att.ld();
  constexpr std::int64_t kRows = 32;  // rows per task (the per-call setup is spread over them)
  detail::for_each_row((att.rows() + kRows - 1) / kRows, e.W * kRows, [&](std::int64_t t) {
    const std::int64_t r0 = t * kRows;
    epilogue_rows(e, ab + r0 * lda, lda, r0, std::min(att.rows(), r0 + kRows));
  });
}

void gat_attention_epilogue_bf16(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                                 const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                                 const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  check_cpu_f32(z, "gat_attention_epilogue_bf16: z");
  Epi e = epilogue_args(GATCORE_EPI_NAMES("gat_attention_epilogue_bf16"), z.rows(), z.cols(), self, self_b, mean, scale, shift, dst, ld);
  gat_fused_additive_forward_rows(g, z, el, er, slope, alpha, &epilogue_rows_sink, &e);
}

}  // namespace gatcore::cpu
GATCORE_TARGET_END
#else
namespace gatcore::cpu {
void gat_epilogue_bf16(const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                       std::uint32_t*, std::int64_t) {
  throw InvalidArgument("gat_epilogue_bf16: needs a CPU with AVX512_BF16");
}
void gat_attention_epilogue_bf16(const CsrGraph&, const Tensor&, const Tensor&, const Tensor&, float, const Tensor&,
                                 const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                                 std::uint32_t*, std::int64_t) {
  throw InvalidArgument("gat_attention_epilogue_bf16: needs a CPU with AVX512_BF16");
}
}  // namespace gatcore::cpu
#endif
