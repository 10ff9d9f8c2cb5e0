// Masked row softmax. The forward has AVX2 / AVX-512 paths (vectorised exp,
// fast_math.hpp); the baseline uses std::exp.
#include "src/backends/cpu/row_softmax.hpp"

#include <cmath>
#include <limits>

#include "src/backends/cpu/fast_math.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"

namespace gatcore::cpu {

namespace {

using detail::check_arg;
using detail::for_each_row;

// One row: y = softmax(x) over columns with mask[c] != 0 (mask may be null).
using SoftmaxRowFn = void (*)(const float* x, const float* mask, float* y, std::int64_t n);

void softmax_row_scalar(const float* x, const float* mask, float* y, std::int64_t n) {
  float m = -std::numeric_limits<float>::infinity();
  for (std::int64_t c = 0; c < n; ++c)
    if (!mask || mask[c] != 0.0f) m = x[c] > m ? x[c] : m;
  if (!(m > -std::numeric_limits<float>::infinity())) {
    // Fully masked row (or every logit -inf): probability 0 everywhere.
    for (std::int64_t c = 0; c < n; ++c) y[c] = 0.0f;
    return;
  }
  float s = 0.0f;
  for (std::int64_t c = 0; c < n; ++c) {
    const float e = (!mask || mask[c] != 0.0f) ? std::exp(x[c] - m) : 0.0f;
    y[c] = e;
    s += e;
  }
  const float inv = 1.0f / s;
  for (std::int64_t c = 0; c < n; ++c) y[c] *= inv;
}

#ifdef GATCORE_X86_SIMD
// Rows up to this many columns keep their exp values in a stack buffer.
constexpr std::int64_t kStackCols = 2048;

GATCORE_TARGET_AVX2 float hsum_avx2(__m256 v) {
  __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  s = _mm_add_ps(s, _mm_movehl_ps(s, s));
  s = _mm_add_ss(s, _mm_movehdup_ps(s));
  return _mm_cvtss_f32(s);
}
GATCORE_TARGET_AVX2 float hmax_avx2(__m256 v) {
  __m128 s = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  s = _mm_max_ps(s, _mm_movehl_ps(s, s));
  s = _mm_max_ss(s, _mm_movehdup_ps(s));
  return _mm_cvtss_f32(s);
}

GATCORE_TARGET_AVX2 void softmax_row_avx2(const float* x, const float* mask, float* y, std::int64_t n) {
  const __m256 ninf = _mm256_set1_ps(-std::numeric_limits<float>::infinity());
  const __m256 zero = _mm256_setzero_ps();
  // Lanes that take part: inside the row and not masked out.
  auto live = [&](std::int64_t c) GATCORE_TARGET_AVX2 {
    __m256 in = _mm256_castsi256_ps(fastmath::tail_mask_avx2(n - c));
    if (mask) {
      const __m256 mv = _mm256_maskload_ps(mask + c, _mm256_castps_si256(in));
      in = _mm256_and_ps(in, _mm256_cmp_ps(mv, zero, _CMP_NEQ_UQ));
    }
    return in;
  };
  __m256 mx = ninf;
  for (std::int64_t c = 0; c < n; c += 8) {
    const __m256 in = live(c);
    const __m256 xv = _mm256_maskload_ps(x + c, _mm256_castps_si256(in));
    mx = _mm256_max_ps(mx, _mm256_blendv_ps(ninf, xv, in));
  }
  const float m = hmax_avx2(mx);
  if (!(m > -std::numeric_limits<float>::infinity())) {
    for (std::int64_t c = 0; c < n; ++c) y[c] = 0.0f;
    return;
  }
  // exp values go to a stack buffer with full-width stores and come back
  // with full-width loads (masked stores do not forward to later loads, which
  // stalls every vector of a short row); y is written once, at the end.
  alignas(64) float buf[kStackCols];
  float* e_out = n <= kStackCols ? buf : y;
  const __m256 mv = _mm256_set1_ps(m);
  __m256 sv = zero;
  for (std::int64_t c = 0; c < n; c += 8) {
    const __m256 in = live(c);
    const __m256 xv = _mm256_maskload_ps(x + c, _mm256_castps_si256(in));
    const __m256 e = _mm256_and_ps(fastmath::exp_avx2(_mm256_sub_ps(xv, mv)), in);
    if (e_out == buf) _mm256_store_ps(buf + c, e);
    else _mm256_maskstore_ps(y + c, fastmath::tail_mask_avx2(n - c), e);
    sv = _mm256_add_ps(sv, e);
  }
  const __m256 inv = _mm256_set1_ps(1.0f / hsum_avx2(sv));
  for (std::int64_t c = 0; c < n; c += 8) {
    const __m256i store = fastmath::tail_mask_avx2(n - c);
    const __m256 e = e_out == buf ? _mm256_load_ps(buf + c) : _mm256_maskload_ps(y + c, store);
    if (n - c >= 8) _mm256_storeu_ps(y + c, _mm256_mul_ps(e, inv));
    else _mm256_maskstore_ps(y + c, store, _mm256_mul_ps(e, inv));
  }
}

GATCORE_TARGET_AVX512 void softmax_row_avx512(const float* x, const float* mask, float* y, std::int64_t n) {
  const __m512 ninf = _mm512_set1_ps(-std::numeric_limits<float>::infinity());
  const __m512 zero = _mm512_setzero_ps();
  auto live = [&](std::int64_t c) GATCORE_TARGET_AVX512 {
    __mmask16 in = n - c >= 16 ? static_cast<__mmask16>(0xffff) : fastmath::tail_mask_avx512(n - c);
    if (mask) in = _mm512_mask_cmp_ps_mask(in, _mm512_maskz_loadu_ps(in, mask + c), zero, _CMP_NEQ_UQ);
    return in;
  };
  __m512 mx = ninf;
  for (std::int64_t c = 0; c < n; c += 16) {
    const __mmask16 in = live(c);
    mx = _mm512_max_ps(mx, _mm512_mask_loadu_ps(ninf, in, x + c));
  }
  const float m = _mm512_reduce_max_ps(mx);
  if (!(m > -std::numeric_limits<float>::infinity())) {
    for (std::int64_t c = 0; c < n; ++c) y[c] = 0.0f;
    return;
  }
  alignas(64) float buf[kStackCols];
  float* e_out = n <= kStackCols ? buf : y;
  const __m512 mv = _mm512_set1_ps(m);
  __m512 sv = zero;
  for (std::int64_t c = 0; c < n; c += 16) {
    const __mmask16 in = live(c);
    const __m512 xv = _mm512_maskz_loadu_ps(in, x + c);
    const __m512 e = _mm512_maskz_mov_ps(in, fastmath::exp_avx512(_mm512_sub_ps(xv, mv)));
    if (e_out == buf) _mm512_store_ps(buf + c, e);
    else _mm512_mask_storeu_ps(y + c, n - c >= 16 ? static_cast<__mmask16>(0xffff) : fastmath::tail_mask_avx512(n - c), e);
    sv = _mm512_add_ps(sv, e);
  }
  const __m512 inv = _mm512_set1_ps(1.0f / _mm512_reduce_add_ps(sv));
  for (std::int64_t c = 0; c < n; c += 16) {
    const __mmask16 store = n - c >= 16 ? static_cast<__mmask16>(0xffff) : fastmath::tail_mask_avx512(n - c);
    const __m512 e = e_out == buf ? _mm512_load_ps(buf + c) : _mm512_maskz_loadu_ps(store, y + c);
    _mm512_mask_storeu_ps(y + c, store, _mm512_mul_ps(e, inv));
  }
}
#endif

SoftmaxRowFn softmax_row_fn() {
#ifdef GATCORE_X86_SIMD
  switch (simd_level()) {
    case SimdLevel::avx512: return &softmax_row_avx512;
    case SimdLevel::avx2: return &softmax_row_avx2;
    case SimdLevel::scalar: break;
  }
#endif
  return &softmax_row_scalar;
}

}  // namespace

void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y) {
  check_cpu_f32(x, "row_softmax_forward: x");
  if (mask.defined()) check_arg(mask, 1, x.cols(), "row_softmax_forward: mask");
  check_arg(y, x.rows(), x.cols(), "row_softmax_forward: y");
  const SoftmaxRowFn fn = softmax_row_fn();
  const float* mp = mask.defined() ? mask.data() : nullptr;
  const std::int64_t n = x.cols();
  if (n == 0) return;
  const float* xp = x.data();
  float* yp = y.data();
  const std::int64_t xld = x.ld(), yld = y.ld();
  for_each_row(x.rows(), n, [&](std::int64_t r) { fn(xp + r * xld, mp, yp + r * yld, n); });
}

void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x) {
  check_cpu_f32(y, "row_softmax_backward: y");
  check_arg(d_y, y.rows(), y.cols(), "row_softmax_backward: d_y");
  if (!d_x.defined()) return;
  check_arg(d_x, y.rows(), y.cols(), "row_softmax_backward: d_x");
  const std::int64_t n = y.cols();
  const float* y0 = y.data();
  const float* g0 = d_y.data();
  float* o0 = d_x.data();
  const std::int64_t yld = y.ld(), gld = d_y.ld(), old = d_x.ld();
  for_each_row(y.rows(), n, [&](std::int64_t r) {
    const float* yp = y0 + r * yld;
    const float* g = g0 + r * gld;
    float* o = o0 + r * old;
    double dot = 0.0;
#pragma omp simd reduction(+ : dot)
    for (std::int64_t c = 0; c < n; ++c) dot += static_cast<double>(yp[c]) * static_cast<double>(g[c]);
    const float d = static_cast<float>(dot);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) o[c] += yp[c] * (g[c] - d);
  });
}

}  // namespace gatcore::cpu
