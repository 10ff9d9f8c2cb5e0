// inference.hpp's bf16 destination: the shared arithmetic
// (gat_epilogue_impl.inc), 32 columns (16 pair words) stored at a time.
#include "src/backends/cpu/inference.hpp"

#include <algorithm>

#include "gatcore/precision.hpp"
#include "src/backends/cpu/fast_math.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
GATCORE_TARGET_BEGIN("avx512f,avx512bw,avx512vl,avx512dq,avx512bf16,avx2,fma")
namespace gatcore::cpu {
namespace {

#include "src/backends/cpu/gat_epilogue_impl.inc"

struct StoreBf16 {
  template <int NV>
  static void row(const Epi& e, std::int64_t r, const __m512 (&y)[NV]) {
    std::uint32_t* d = e.dst + r * e.ld;
#pragma GCC unroll 8
    for (int v = 0; v < NV; v += 2) {
      const __mmask16 words = lanes((e.W - 16 * v + 1) / 2);
      if (v + 1 < NV)
        _mm512_mask_storeu_epi32(d + 8 * v, words, (__m512i)_mm512_cvtne2ps_pbh(y[v + 1], y[v]));
      else  // the same rounding, one vector
        _mm256_mask_storeu_epi32(d + 8 * v, __mmask8(words), (__m256i)_mm512_cvtneps_pbh(y[v]));
    }
  }
  static void pair(const Epi& e, std::int64_t r, std::int64_t c, __m512 lo, __m512 hi) {
    // Zeroed lanes past W give a zero high half for an odd W (bf16_pairs' layout).
    _mm512_mask_storeu_epi32(e.dst + r * e.ld + c / 2, lanes((e.W - c + 1) / 2), (__m512i)_mm512_cvtne2ps_pbh(hi, lo));
  }
};

Epi bf16_args(const Names& nm, std::int64_t n, std::int64_t kf, const Tensor& self, const Tensor& self_b,
              const Tensor& mean, const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  GATCORE_CHECK(bf16_supported(), nm.fn, ": needs a CPU with AVX512_BF16");
  Epi e = epilogue_args(nm, n, kf, self, self_b, mean, scale, shift);
  GATCORE_CHECK(ld >= (e.W + 1) / 2, nm.fn, ": ld ", ld, " below ", (e.W + 1) / 2, " words");
  GATCORE_CHECK(dst || n == 0, nm.fn, ": no destination");
  e.dst = dst;
  e.ld = ld;
  return e;
}

}  // namespace

void gat_epilogue_bf16(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                       const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  check_cpu_f32(att, "gat_epilogue_bf16: att");
  const Epi e = bf16_args(GATCORE_EPI_NAMES("gat_epilogue_bf16"), att.rows(), att.cols(), self, self_b, mean, scale,
                          shift, dst, ld);
  epilogue_all_rows<StoreBf16>(e, att);
}

void gat_attention_epilogue_bf16(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                                 const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                                 const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld) {
  check_cpu_f32(z, "gat_attention_epilogue_bf16: z");
  Epi e = bf16_args(GATCORE_EPI_NAMES("gat_attention_epilogue_bf16"), z.rows(), z.cols(), self, self_b, mean, scale,
                    shift, dst, ld);
  gat_fused_additive_forward_rows(g, z, el, er, slope, alpha, &epilogue_rows_sink<StoreBf16>, &e);
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
