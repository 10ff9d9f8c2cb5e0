// gat_epilogue_bf16.hpp: one AVX-512 pass per row, 32 columns (16 pair words) at a time.
#include "kernels/gat_epilogue_bf16.hpp"

#include <algorithm>

#include "gatcore/precision.hpp"
#include "kernels/fast_math.hpp"
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

}  // namespace

void gat_epilogue_bf16(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                       const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  GATCORE_CHECK(bf16_supported(), "gat_epilogue_bf16: needs a CPU with AVX512_BF16");
  check_cpu_f32(att, "gat_epilogue_bf16: att");
  const std::int64_t n = att.rows(), kf = att.cols(), S = self.defined() ? self.cols() : 0, W = kf + S;
  if (self.defined()) detail::check_arg(self, n, S, "gat_epilogue_bf16: self");
  GATCORE_CHECK(ld >= (W + 1) / 2, "gat_epilogue_bf16: ld ", ld, " below ", (W + 1) / 2, " words");
  if (self_b.defined()) detail::check_arg(self_b, 1, S, "gat_epilogue_bf16: self_b");
  const bool affine = mean.defined();
  if (affine) {
    detail::check_arg(mean, 1, W, "gat_epilogue_bf16: mean");
    detail::check_arg(scale, 1, W, "gat_epilogue_bf16: scale");
    detail::check_arg(shift, 1, W, "gat_epilogue_bf16: shift");
  }
  const float* bias = self_b.defined() && S > 0 ? self_b.data() : nullptr;
  // Row pointers from bases and strides (Tensor::row is out of line: a call per row and block showed in profiles).
  const float* ab = att.data();
  const float* sb = S > 0 ? self.data() : nullptr;
  const std::int64_t lda = att.ld(), lds = S > 0 ? self.ld() : 0;
  const float* m = affine ? mean.data() : nullptr;
  const float* s = affine ? scale.data() : nullptr;
  const float* b = affine ? shift.data() : nullptr;
  detail::for_each_row(n, W, [&](std::int64_t r) {
    const float* a = ab + r * lda;
    const float* sr = sb ? sb + r * lds : nullptr;
    std::uint32_t* d = dst + r * ld;
    for (std::int64_t c = 0; c < W; c += 32) {
      const __m512 lo = epilogue16(a, sr, c, W, kf, bias, m, s, b);
      const __m512 hi = epilogue16(a, sr, c + 16, W, kf, bias, m, s, b);
      // Zeroed lanes past W give a zero high half for an odd W (bf16_pairs' layout).
      _mm512_mask_storeu_epi32(d + c / 2, lanes((W - c + 1) / 2), (__m512i)_mm512_cvtne2ps_pbh(hi, lo));
    }
  });
}

}  // namespace gatcore::cpu
GATCORE_TARGET_END
#else
namespace gatcore::cpu {
void gat_epilogue_bf16(const Tensor&, std::int64_t, const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                       std::uint32_t*, std::int64_t) {
  throw InvalidArgument("gat_epilogue_bf16: needs a CPU with AVX512_BF16");
}
}  // namespace gatcore::cpu
#endif
