#pragma once
// Internal: vectorisable float approximations of tanh and exp, with explicit
// AVX2 / AVX-512 versions. The vector versions evaluate exactly the same
// operation sequence as the FMA scalar version, so a row gives the same
// result whichever lanes its elements land in (tails included).
//
// tanh: Eigen's rational approximation (odd degree-13 / even degree-6
// polynomial on [-7.9053, 7.9053], identity below |x| < 4e-4): max absolute
// and relative error ~3e-7 over all floats; NaN propagates; ±inf -> ±(1-2.4e-7).
// exp: Cody-Waite range reduction + degree-6 polynomial, ~2 ulp; underflows to
// 0 below -87.3, overflows to +inf above 88.7, NaN propagates.
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
// GCC 12 flags the _mm512_undefined_* idiom inside its own AVX-512 headers as
// -Wmaybe-uninitialized once they are inlined into target("avx512f")
// functions (a false positive, GCC PR105593); the diagnostic state is taken
// from the header lines, so it is set around the include.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#define GATCORE_X86_SIMD 1
#define GATCORE_TARGET_AVX2 __attribute__((target("avx2,fma")))
#define GATCORE_TARGET_AVX512 __attribute__((target("avx512f,avx512bw,avx512vl,avx512dq,avx2,fma")))
#endif

namespace gatcore::cpu::fastmath {

inline constexpr float kTanhClamp = 7.90531110763549805f;
inline constexpr float kTanhTiny = 0.0004f;
inline constexpr float kTanhA13 = -2.76076847742355e-16f;
inline constexpr float kTanhA11 = 2.00018790482477e-13f;
inline constexpr float kTanhA9 = -8.60467152213735e-11f;
inline constexpr float kTanhA7 = 5.12229709037114e-08f;
inline constexpr float kTanhA5 = 1.48572235717979e-05f;
inline constexpr float kTanhA3 = 6.37261928875436e-04f;
inline constexpr float kTanhA1 = 4.89352455891786e-03f;
inline constexpr float kTanhB6 = 1.19825839466702e-06f;
inline constexpr float kTanhB4 = 1.18534705686654e-04f;
inline constexpr float kTanhB2 = 2.26843463243900e-03f;
inline constexpr float kTanhB0 = 4.89352518554385e-03f;

// Baseline scalar version (no FMA: the baseline ISA has none; separate
// multiply and add). Vectorises with SSE2 under `#pragma omp simd`.
inline float tanh_nofma(float x) {
  // Clamp written so that NaN passes through (comparisons with NaN are false).
  const float xc = x < -kTanhClamp ? -kTanhClamp : (x > kTanhClamp ? kTanhClamp : x);
  const float x2 = xc * xc;
  float p = kTanhA13;
  p = p * x2 + kTanhA11;
  p = p * x2 + kTanhA9;
  p = p * x2 + kTanhA7;
  p = p * x2 + kTanhA5;
  p = p * x2 + kTanhA3;
  p = p * x2 + kTanhA1;
  p = p * xc;
  float q = kTanhB6;
  q = q * x2 + kTanhB4;
  q = q * x2 + kTanhB2;
  q = q * x2 + kTanhB0;
  const float r = p / q;
  const float ax = x < 0.0f ? -x : x;
  return ax < kTanhTiny ? x : r;
}

// exp: x = n ln2 + r, |r| <= ln2/2; exp(r) by a degree-6 polynomial (Cephes expf).
inline constexpr float kExpHi = 88.7228394f;   // exp(kExpHi) ~ FLT_MAX
inline constexpr float kExpLo = -87.3365479f;  // exp(kExpLo) ~ FLT_MIN (below: 0)
inline constexpr float kLog2e = 1.44269504088896341f;
inline constexpr float kLn2Hi = 0.693359375f;
inline constexpr float kLn2Lo = -2.12194440e-4f;
inline constexpr float kExpP0 = 1.9875691500e-4f;
inline constexpr float kExpP1 = 1.3981999507e-3f;
inline constexpr float kExpP2 = 8.3334519073e-3f;
inline constexpr float kExpP3 = 4.1665795894e-2f;
inline constexpr float kExpP4 = 1.6666665459e-1f;
inline constexpr float kExpP5 = 5.0000001201e-1f;

inline float exp_nofma(float x) {
  if (x != x) return x;
  if (x > kExpHi) return INFINITY;
  if (x < kExpLo) return 0.0f;
  const float n = std::nearbyint(x * kLog2e);
  float r = x - n * kLn2Hi;
  r = r - n * kLn2Lo;
  const float r2 = r * r;
  float p = kExpP0;
  p = p * r + kExpP1;
  p = p * r + kExpP2;
  p = p * r + kExpP3;
  p = p * r + kExpP4;
  p = p * r + kExpP5;
  p = p * r2 + r;
  p = p + 1.0f;
  // scale by 2^n (n in [-126, 128]; split in two steps so 2^n never overflows)
  const int ni = static_cast<int>(n);
  const int n1 = ni >> 1, n2 = ni - n1;  // floor(n/2), as the vector versions
  std::uint32_t b1 = static_cast<std::uint32_t>(n1 + 127) << 23, b2 = static_cast<std::uint32_t>(n2 + 127) << 23;
  float s1, s2;
  std::memcpy(&s1, &b1, 4);
  std::memcpy(&s2, &b2, 4);
  return p * s1 * s2;
}

#ifdef GATCORE_X86_SIMD

// ---- SSE2 (the x86-64 baseline) ---------------------------------------------------
// The scalar tanh_nofma does not auto-vectorise (GCC will not if-convert its
// selects under -ftrapping-math), so the baseline gets SSE2 intrinsics: the
// same operation sequence as tanh_nofma, four lanes at a time.
inline __m128 tanh_sse2(__m128 x) {
  const __m128 c = _mm_set1_ps(kTanhClamp);
  const __m128 xc = _mm_min_ps(c, _mm_max_ps(_mm_sub_ps(_mm_setzero_ps(), c), x));  // NaN passes
  const __m128 x2 = _mm_mul_ps(xc, xc);
  __m128 p = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(kTanhA13), x2), _mm_set1_ps(kTanhA11));
  p = _mm_add_ps(_mm_mul_ps(p, x2), _mm_set1_ps(kTanhA9));
  p = _mm_add_ps(_mm_mul_ps(p, x2), _mm_set1_ps(kTanhA7));
  p = _mm_add_ps(_mm_mul_ps(p, x2), _mm_set1_ps(kTanhA5));
  p = _mm_add_ps(_mm_mul_ps(p, x2), _mm_set1_ps(kTanhA3));
  p = _mm_add_ps(_mm_mul_ps(p, x2), _mm_set1_ps(kTanhA1));
  p = _mm_mul_ps(p, xc);
  __m128 q = _mm_add_ps(_mm_mul_ps(_mm_set1_ps(kTanhB6), x2), _mm_set1_ps(kTanhB4));
  q = _mm_add_ps(_mm_mul_ps(q, x2), _mm_set1_ps(kTanhB2));
  q = _mm_add_ps(_mm_mul_ps(q, x2), _mm_set1_ps(kTanhB0));
  const __m128 r = _mm_div_ps(p, q);
  const __m128 ax = _mm_andnot_ps(_mm_set1_ps(-0.0f), x);
  const __m128 tiny = _mm_cmplt_ps(ax, _mm_set1_ps(kTanhTiny));
  return _mm_or_ps(_mm_and_ps(tiny, x), _mm_andnot_ps(tiny, r));
}

// ---- AVX2 -----------------------------------------------------------------------
GATCORE_TARGET_AVX2 inline __m256 tanh_avx2(__m256 x) {
  const __m256 c = _mm256_set1_ps(kTanhClamp);
  // max(-c, x): returns x when x is NaN (second operand), min likewise.
  const __m256 xc = _mm256_min_ps(c, _mm256_max_ps(_mm256_sub_ps(_mm256_setzero_ps(), c), x));
  const __m256 x2 = _mm256_mul_ps(xc, xc);
  __m256 p = _mm256_fmadd_ps(_mm256_set1_ps(kTanhA13), x2, _mm256_set1_ps(kTanhA11));
  p = _mm256_fmadd_ps(p, x2, _mm256_set1_ps(kTanhA9));
  p = _mm256_fmadd_ps(p, x2, _mm256_set1_ps(kTanhA7));
  p = _mm256_fmadd_ps(p, x2, _mm256_set1_ps(kTanhA5));
  p = _mm256_fmadd_ps(p, x2, _mm256_set1_ps(kTanhA3));
  p = _mm256_fmadd_ps(p, x2, _mm256_set1_ps(kTanhA1));
  p = _mm256_mul_ps(p, xc);
  __m256 q = _mm256_fmadd_ps(_mm256_set1_ps(kTanhB6), x2, _mm256_set1_ps(kTanhB4));
  q = _mm256_fmadd_ps(q, x2, _mm256_set1_ps(kTanhB2));
  q = _mm256_fmadd_ps(q, x2, _mm256_set1_ps(kTanhB0));
  const __m256 r = _mm256_div_ps(p, q);
  const __m256 ax = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), x);
  const __m256 tiny = _mm256_cmp_ps(ax, _mm256_set1_ps(kTanhTiny), _CMP_LT_OQ);
  return _mm256_blendv_ps(r, x, tiny);
}

GATCORE_TARGET_AVX2 inline __m256 exp_avx2(__m256 x) {
  const __m256 nan = _mm256_cmp_ps(x, x, _CMP_UNORD_Q);
  const __m256 over = _mm256_cmp_ps(x, _mm256_set1_ps(kExpHi), _CMP_GT_OQ);
  const __m256 under = _mm256_cmp_ps(x, _mm256_set1_ps(kExpLo), _CMP_LT_OQ);
  const __m256 xc = _mm256_min_ps(_mm256_max_ps(x, _mm256_set1_ps(kExpLo)), _mm256_set1_ps(kExpHi));
  const __m256 n = _mm256_round_ps(_mm256_mul_ps(xc, _mm256_set1_ps(kLog2e)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m256 r = _mm256_fnmadd_ps(n, _mm256_set1_ps(kLn2Hi), xc);
  r = _mm256_fnmadd_ps(n, _mm256_set1_ps(kLn2Lo), r);
  const __m256 r2 = _mm256_mul_ps(r, r);
  __m256 p = _mm256_fmadd_ps(_mm256_set1_ps(kExpP0), r, _mm256_set1_ps(kExpP1));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(kExpP2));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(kExpP3));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(kExpP4));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(kExpP5));
  p = _mm256_fmadd_ps(p, r2, r);
  p = _mm256_add_ps(p, _mm256_set1_ps(1.0f));
  const __m256i ni = _mm256_cvtps_epi32(n);
  const __m256i n1 = _mm256_srai_epi32(ni, 1);  // floor(n/2)
  const __m256i n2 = _mm256_sub_epi32(ni, n1);
  const __m256i bias = _mm256_set1_epi32(127);
  const __m256 s1 = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(n1, bias), 23));
  const __m256 s2 = _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(n2, bias), 23));
  __m256 y = _mm256_mul_ps(_mm256_mul_ps(p, s1), s2);
  y = _mm256_blendv_ps(y, _mm256_setzero_ps(), under);
  y = _mm256_blendv_ps(y, _mm256_set1_ps(INFINITY), over);
  return _mm256_blendv_ps(y, x, nan);
}

// Lane mask for the first `k` (0..8) lanes, for maskload/maskstore.
GATCORE_TARGET_AVX2 inline __m256i tail_mask_avx2(std::int64_t k) {
  const __m256i idx = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  return _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(k)), idx);
}

// ---- AVX-512 --------------------------------------------------------------------
GATCORE_TARGET_AVX512 inline __m512 tanh_avx512(__m512 x) {
  const __m512 c = _mm512_set1_ps(kTanhClamp);
  const __m512 xc = _mm512_min_ps(c, _mm512_max_ps(_mm512_sub_ps(_mm512_setzero_ps(), c), x));
  const __m512 x2 = _mm512_mul_ps(xc, xc);
  __m512 p = _mm512_fmadd_ps(_mm512_set1_ps(kTanhA13), x2, _mm512_set1_ps(kTanhA11));
  p = _mm512_fmadd_ps(p, x2, _mm512_set1_ps(kTanhA9));
  p = _mm512_fmadd_ps(p, x2, _mm512_set1_ps(kTanhA7));
  p = _mm512_fmadd_ps(p, x2, _mm512_set1_ps(kTanhA5));
  p = _mm512_fmadd_ps(p, x2, _mm512_set1_ps(kTanhA3));
  p = _mm512_fmadd_ps(p, x2, _mm512_set1_ps(kTanhA1));
  p = _mm512_mul_ps(p, xc);
  __m512 q = _mm512_fmadd_ps(_mm512_set1_ps(kTanhB6), x2, _mm512_set1_ps(kTanhB4));
  q = _mm512_fmadd_ps(q, x2, _mm512_set1_ps(kTanhB2));
  q = _mm512_fmadd_ps(q, x2, _mm512_set1_ps(kTanhB0));
  const __m512 r = _mm512_div_ps(p, q);
  const __mmask16 tiny = _mm512_cmp_ps_mask(_mm512_abs_ps(x), _mm512_set1_ps(kTanhTiny), _CMP_LT_OQ);
  return _mm512_mask_blend_ps(tiny, r, x);
}

GATCORE_TARGET_AVX512 inline __m512 exp_avx512(__m512 x) {
  const __mmask16 nan = _mm512_cmp_ps_mask(x, x, _CMP_UNORD_Q);
  const __mmask16 over = _mm512_cmp_ps_mask(x, _mm512_set1_ps(kExpHi), _CMP_GT_OQ);
  const __mmask16 under = _mm512_cmp_ps_mask(x, _mm512_set1_ps(kExpLo), _CMP_LT_OQ);
  const __m512 xc = _mm512_min_ps(_mm512_max_ps(x, _mm512_set1_ps(kExpLo)), _mm512_set1_ps(kExpHi));
  const __m512 n =
      _mm512_roundscale_ps(_mm512_mul_ps(xc, _mm512_set1_ps(kLog2e)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m512 r = _mm512_fnmadd_ps(n, _mm512_set1_ps(kLn2Hi), xc);
  r = _mm512_fnmadd_ps(n, _mm512_set1_ps(kLn2Lo), r);
  const __m512 r2 = _mm512_mul_ps(r, r);
  __m512 p = _mm512_fmadd_ps(_mm512_set1_ps(kExpP0), r, _mm512_set1_ps(kExpP1));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(kExpP2));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(kExpP3));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(kExpP4));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(kExpP5));
  p = _mm512_fmadd_ps(p, r2, r);
  p = _mm512_add_ps(p, _mm512_set1_ps(1.0f));
  const __m512i ni = _mm512_cvtps_epi32(n);
  const __m512i n1 = _mm512_srai_epi32(ni, 1);
  const __m512i n2 = _mm512_sub_epi32(ni, n1);
  const __m512i bias = _mm512_set1_epi32(127);
  const __m512 s1 = _mm512_castsi512_ps(_mm512_slli_epi32(_mm512_add_epi32(n1, bias), 23));
  const __m512 s2 = _mm512_castsi512_ps(_mm512_slli_epi32(_mm512_add_epi32(n2, bias), 23));
  __m512 y = _mm512_mul_ps(_mm512_mul_ps(p, s1), s2);
  y = _mm512_mask_blend_ps(under, y, _mm512_setzero_ps());
  y = _mm512_mask_blend_ps(over, y, _mm512_set1_ps(INFINITY));
  return _mm512_mask_blend_ps(nan, y, x);
}

GATCORE_TARGET_AVX512 inline __mmask16 tail_mask_avx512(std::int64_t k) {
  return static_cast<__mmask16>((1u << k) - 1u);
}

#endif  // GATCORE_X86_SIMD

}  // namespace gatcore::cpu::fastmath
