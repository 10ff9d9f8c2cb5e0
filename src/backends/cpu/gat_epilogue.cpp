// inference.hpp's fp32 destination: the shared arithmetic
// (gat_epilogue_impl.inc), 16 columns stored at a time. Compiled for
// AVX-512F (no AVX512_BF16: the fp32 kernels run on every AVX-512 CPU).
#include "src/backends/cpu/inference.hpp"

#include <algorithm>

#include "src/backends/cpu/fast_math.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
GATCORE_TARGET_BEGIN("avx512f,avx512bw,avx512vl,avx512dq,avx2,fma")
namespace gatcore::cpu {
namespace {

#include "src/backends/cpu/gat_epilogue_impl.inc"

struct StoreF32 {
  template <int NV>
  static void row(const Epi& e, std::int64_t r, const __m512 (&y)[NV]) {
    float* d = e.out + r * e.ldo;
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) _mm512_mask_storeu_ps(d + 16 * v, lanes(e.W - 16 * v), y[v]);
  }
  static void pair(const Epi& e, std::int64_t r, std::int64_t c, __m512 lo, __m512 hi) {
    float* d = e.out + r * e.ldo;
    _mm512_mask_storeu_ps(d + c, lanes(e.W - c), lo);
    _mm512_mask_storeu_ps(d + c + 16, lanes(e.W - c - 16), hi);
  }
};

// The destination's checks; `inputs` are what the kernel reads while it writes out.
Epi f32_args(const Names& nm, std::int64_t n, std::int64_t kf, const Tensor& self, const Tensor& self_b,
             const Tensor& mean, const Tensor& scale, const Tensor& shift, const Tensor& out,
             std::initializer_list<const Tensor*> inputs) {
  GATCORE_CHECK(gat_epilogue_supported(), nm.fn, ": needs the AVX-512 SIMD level (active: ",
                simd_level_name(simd_level()), "); below it, compose add_row_bias, activation_forward and "
                "batchnorm_affine_forward");
  Epi e = epilogue_args(nm, n, kf, self, self_b, mean, scale, shift);
  detail::check_arg(out, n, e.W, nm.out);
  for (const Tensor* t : inputs)
    GATCORE_CHECK(!detail::views_overlap(out, *t), nm.fn, ": out ", out.shape_str(), " overlaps an input ",
                  t->shape_str(), " (the output must not alias an input)");
  e.out = out.data();
  e.ldo = out.ld();
  return e;
}

}  // namespace

bool gat_epilogue_supported() { return simd_level() == SimdLevel::avx512; }

void gat_epilogue(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                  const Tensor& scale, const Tensor& shift, const Tensor& out) {
  check_cpu_f32(att, "gat_epilogue: att");
  const Epi e = f32_args(GATCORE_EPI_NAMES("gat_epilogue"), att.rows(), att.cols(), self, self_b, mean, scale, shift,
                         out, {&att, &self});
  epilogue_all_rows<StoreF32>(e, att);
}

void gat_attention_epilogue(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                            const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                            const Tensor& scale, const Tensor& shift, const Tensor& out) {
  check_cpu_f32(z, "gat_attention_epilogue: z");
  Epi e = f32_args(GATCORE_EPI_NAMES("gat_attention_epilogue"), z.rows(), z.cols(), self, self_b, mean, scale, shift,
                   out, {&z, &el, &er, &self, &alpha});
  gat_fused_additive_forward_rows(g, z, el, er, slope, alpha, &epilogue_rows_sink<StoreF32>, &e);
}

}  // namespace gatcore::cpu
GATCORE_TARGET_END
#else
namespace gatcore::cpu {
bool gat_epilogue_supported() { return false; }
void gat_epilogue(const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                  const Tensor&) {
  throw InvalidArgument("gat_epilogue: needs an x86-64 CPU with AVX-512");
}
void gat_attention_epilogue(const CsrGraph&, const Tensor&, const Tensor&, const Tensor&, float, const Tensor&,
                            const Tensor&, const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                            const Tensor&) {
  throw InvalidArgument("gat_attention_epilogue: needs an x86-64 CPU with AVX-512");
}
}  // namespace gatcore::cpu
#endif
