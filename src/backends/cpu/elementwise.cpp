// Elementwise kernels and reductions. Row-parallel (static schedule), inner
// loops over contiguous columns. tanh / tanhshrink (applied by DenseGATs to
// every activation) have AVX2 and AVX-512 paths chosen from cpu::simd_level();
// the other elementwise kernels are memory bound and auto-vectorised.
#include "src/backends/cpu/elementwise.hpp"

#include <algorithm>
#include <cstring>

#include "src/backends/cpu/fast_math.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"

namespace gatcore::cpu {

namespace {

using detail::check_arg;
using detail::for_each_row;
using detail::with_output_base;


// ---- tanh row kernels -----------------------------------------------------------
// Mode: what a row kernel computes from t = tanh(x[i]).
enum TanhMode : int {
  kTanhFwd = 0,       // out = t
  kShrinkFwd = 1,     // out = x - t
  kShrinkBwd = 2,     // out += t^2 * dy
  kTanhBwdFromX = 3,  // out += (1 - t)(1 + t) * dy
  // The backward modes writing out (its old contents ignored) instead of
  // adding to it: the sum onto a zero vector, so the bits of accumulating
  // onto a zero-filled out (activation_backward's accumulate = false).
  kShrinkBwdSet = 4,
  kTanhBwdFromXSet = 5,
};
// The arithmetic of a mode (a write mode computes as its accumulating one).
constexpr int math_mode(int mode) { return mode >= kShrinkBwdSet ? mode - 2 : mode; }
// Whether a mode reads dy / adds onto out.
constexpr bool is_bwd(int mode) { return mode != kTanhFwd && mode != kShrinkFwd; }
constexpr bool adds_to_out(int mode) { return mode == kShrinkBwd || mode == kTanhBwdFromX; }

using TanhRowFn = void (*)(const float* x, const float* dy, float* out, std::int64_t n);

template <int Mode>
void tanh_row_scalar(const float* x, const float* dy, float* out, std::int64_t n) {
#pragma omp simd
  for (std::int64_t i = 0; i < n; ++i) {
    const float t = fastmath::tanh_nofma(x[i]);
    const float o = adds_to_out(Mode) ? out[i] : 0.0f;
    if constexpr (Mode == kTanhFwd) out[i] = t;
    else if constexpr (Mode == kShrinkFwd) out[i] = x[i] - t;
    else if constexpr (math_mode(Mode) == kShrinkBwd) out[i] = o + t * t * dy[i];
    else out[i] = o + (1.0f - t) * (1.0f + t) * dy[i];
  }
}

#ifdef GATCORE_X86_SIMD
template <int Mode>
inline __m128 tanh_mode_sse2(__m128 xv, __m128 dyv, __m128 ov) {
  const __m128 t = fastmath::tanh_sse2(xv);
  if constexpr (Mode == kTanhFwd) return t;
  else if constexpr (Mode == kShrinkFwd) return _mm_sub_ps(xv, t);
  else if constexpr (math_mode(Mode) == kShrinkBwd) return _mm_add_ps(_mm_mul_ps(_mm_mul_ps(t, t), dyv), ov);
  else {
    const __m128 one = _mm_set1_ps(1.0f);
    const __m128 d = _mm_mul_ps(_mm_sub_ps(one, t), _mm_add_ps(one, t));
    return _mm_add_ps(_mm_mul_ps(d, dyv), ov);
  }
}

template <int Mode>
void tanh_row_sse2(const float* x, const float* dy, float* out, std::int64_t n) {
  constexpr bool kBwd = is_bwd(Mode), kAdd = adds_to_out(Mode);
  std::int64_t i = 0;
  for (; i + 4 <= n; i += 4) {
    const __m128 xv = _mm_loadu_ps(x + i);
    const __m128 dyv = kBwd ? _mm_loadu_ps(dy + i) : _mm_setzero_ps();
    const __m128 ov = kAdd ? _mm_loadu_ps(out + i) : _mm_setzero_ps();
    _mm_storeu_ps(out + i, tanh_mode_sse2<Mode>(xv, dyv, ov));
  }
  if (i < n) {  // tail through a padded copy
    alignas(16) float xt[4] = {0, 0, 0, 0}, dt[4] = {0, 0, 0, 0}, ot[4] = {0, 0, 0, 0};
    for (std::int64_t k = 0; k < n - i; ++k) {
      xt[k] = x[i + k];
      if (kBwd) dt[k] = dy[i + k];
      if (kAdd) ot[k] = out[i + k];
    }
    _mm_store_ps(ot, tanh_mode_sse2<Mode>(_mm_load_ps(xt), _mm_load_ps(dt), _mm_load_ps(ot)));
    for (std::int64_t k = 0; k < n - i; ++k) out[i + k] = ot[k];
  }
}

template <int Mode>
GATCORE_TARGET_AVX2 inline __m256 tanh_mode_avx2(__m256 xv, __m256 dyv, __m256 ov) {
  const __m256 t = fastmath::tanh_avx2(xv);
  if constexpr (Mode == kTanhFwd) return t;
  else if constexpr (Mode == kShrinkFwd) return _mm256_sub_ps(xv, t);
  else if constexpr (math_mode(Mode) == kShrinkBwd) return _mm256_fmadd_ps(_mm256_mul_ps(t, t), dyv, ov);
  else {
    const __m256 one = _mm256_set1_ps(1.0f);
    const __m256 d = _mm256_mul_ps(_mm256_sub_ps(one, t), _mm256_add_ps(one, t));
    return _mm256_fmadd_ps(d, dyv, ov);
  }
}

template <int Mode>
GATCORE_TARGET_AVX2 void tanh_row_avx2(const float* x, const float* dy, float* out, std::int64_t n) {
  constexpr bool kBwd = is_bwd(Mode), kAdd = adds_to_out(Mode);
  std::int64_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 xv = _mm256_loadu_ps(x + i);
    const __m256 dyv = kBwd ? _mm256_loadu_ps(dy + i) : _mm256_setzero_ps();
    const __m256 ov = kAdd ? _mm256_loadu_ps(out + i) : _mm256_setzero_ps();
    _mm256_storeu_ps(out + i, tanh_mode_avx2<Mode>(xv, dyv, ov));
  }
  if (i < n) {
    const __m256i m = fastmath::tail_mask_avx2(n - i);
    const __m256 xv = _mm256_maskload_ps(x + i, m);
    const __m256 dyv = kBwd ? _mm256_maskload_ps(dy + i, m) : _mm256_setzero_ps();
    const __m256 ov = kAdd ? _mm256_maskload_ps(out + i, m) : _mm256_setzero_ps();
    _mm256_maskstore_ps(out + i, m, tanh_mode_avx2<Mode>(xv, dyv, ov));
  }
}

template <int Mode>
GATCORE_TARGET_AVX512 inline __m512 tanh_mode_avx512(__m512 xv, __m512 dyv, __m512 ov) {
  const __m512 t = fastmath::tanh_avx512(xv);
  if constexpr (Mode == kTanhFwd) return t;
  else if constexpr (Mode == kShrinkFwd) return _mm512_sub_ps(xv, t);
  else if constexpr (math_mode(Mode) == kShrinkBwd) return _mm512_fmadd_ps(_mm512_mul_ps(t, t), dyv, ov);
  else {
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 d = _mm512_mul_ps(_mm512_sub_ps(one, t), _mm512_add_ps(one, t));
    return _mm512_fmadd_ps(d, dyv, ov);
  }
}

template <int Mode>
GATCORE_TARGET_AVX512 void tanh_row_avx512(const float* x, const float* dy, float* out, std::int64_t n) {
  constexpr bool kBwd = is_bwd(Mode), kAdd = adds_to_out(Mode);
  std::int64_t i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m512 xv = _mm512_loadu_ps(x + i);
    const __m512 dyv = kBwd ? _mm512_loadu_ps(dy + i) : _mm512_setzero_ps();
    const __m512 ov = kAdd ? _mm512_loadu_ps(out + i) : _mm512_setzero_ps();
    _mm512_storeu_ps(out + i, tanh_mode_avx512<Mode>(xv, dyv, ov));
  }
  if (i < n) {
    const __mmask16 m = fastmath::tail_mask_avx512(n - i);
    const __m512 xv = _mm512_maskz_loadu_ps(m, x + i);
    const __m512 dyv = kBwd ? _mm512_maskz_loadu_ps(m, dy + i) : _mm512_setzero_ps();
    const __m512 ov = kAdd ? _mm512_maskz_loadu_ps(m, out + i) : _mm512_setzero_ps();
    _mm512_mask_storeu_ps(out + i, m, tanh_mode_avx512<Mode>(xv, dyv, ov));
  }
}
#endif

template <int Mode>
TanhRowFn tanh_row_fn() {
#ifdef GATCORE_X86_SIMD
  switch (simd_level()) {
    case SimdLevel::avx512: return &tanh_row_avx512<Mode>;
    case SimdLevel::avx2: return &tanh_row_avx2<Mode>;
    case SimdLevel::scalar: return &tanh_row_sse2<Mode>;
  }
#endif
  return &tanh_row_scalar<Mode>;
}

template <int Mode>
void run_tanh_rows(const Tensor& x, const Tensor& dy, const Tensor& out) {
  const TanhRowFn fn = tanh_row_fn<Mode>();
  const float* xp = x.data();
  const float* dyp = dy.defined() ? dy.data() : nullptr;
  float* op = out.data();
  const std::int64_t n = x.cols(), xld = x.ld(), dld = dy.defined() ? dy.ld() : 0, old = out.ld();
  for_each_row(x.rows(), n, [&](std::int64_t r) { fn(xp + r * xld, dyp ? dyp + r * dld : nullptr, op + r * old, n); });
}

}  // namespace

// ---- activations -------------------------------------------------------------------

void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope) {
  check_cpu_f32(x, "activation_forward: x");
  check_arg(y, x.rows(), x.cols(), "activation_forward: y");
  const std::int64_t n = x.cols();
  switch (f) {
    case Activation::identity:
      if (x.data() == y.data() && x.ld() == y.ld()) return;
      for_each_row(x.rows(), n, [&](std::int64_t r) { std::memmove(y.row(r), x.row(r), n * sizeof(float)); });
      return;
    case Activation::tanh: run_tanh_rows<kTanhFwd>(x, Tensor(), y); return;
    case Activation::tanhshrink: run_tanh_rows<kShrinkFwd>(x, Tensor(), y); return;
    case Activation::leaky_relu:
      // x times a selected constant: `x < 0 ? slope * x : x` keeps its
      // multiply inside the branch (it may raise an FP exception, so GCC
      // will not run it speculatively) and was compiled as a scalar loop with
      // a branch per element, mispredicted on half of them: 16 % of an
      // Ori.GAT training step. Selecting between two constants and then
      // multiplying vectorises, and gives the same values (x * 1 is x, NaN
      // and -0 included).
      for_each_row(x.rows(), n, [&](std::int64_t r) {
        const float* xp = x.row(r);
        float* yp = y.row(r);
        const float a = slope;  // a register, not a load inside the select
#pragma omp simd
        for (std::int64_t c = 0; c < n; ++c) yp[c] = xp[c] * (xp[c] < 0.0f ? a : 1.0f);
      });
      return;
    case Activation::relu:
      for_each_row(x.rows(), n, [&](std::int64_t r) {
        const float* xp = x.row(r);
        float* yp = y.row(r);
#pragma omp simd
        for (std::int64_t c = 0; c < n; ++c) yp[c] = xp[c] < 0.0f ? 0.0f : xp[c];  // NaN passes
      });
      return;
  }
  GATCORE_CHECK(false, "activation_forward: unknown activation ", static_cast<int>(f));
}

void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y, const Tensor& d_x,
                         float slope, bool accumulate) {
  check_cpu_f32(d_y, "activation_backward: d_y");
  const std::int64_t rows = d_y.rows(), n = d_y.cols();
  if (x.defined()) check_arg(x, rows, n, "activation_backward: x");
  if (y.defined()) check_arg(y, rows, n, "activation_backward: y");
  // What the derivative is computed from.
  const bool needs_input = f != Activation::identity;
  GATCORE_CHECK(!needs_input || x.defined() || (y.defined() && f != Activation::tanhshrink),
                "activation_backward(", activation_name(f), "): x: tensor is undefined",
                f == Activation::tanhshrink ? " (tanhshrink needs x)" : " (and y is undefined too)");
  if (!d_x.defined()) return;
  check_arg(d_x, rows, n, "activation_backward: d_x");
  // o = base + term (with_output_base): a fresh gradient is written without
  // a zero fill first (a pass over d_x, serial in memset).
  const auto rows_loop = [&](auto term) {
    with_output_base(accumulate, [&](auto base) {
      for_each_row(rows, n, [&](std::int64_t r) { term(r, d_x.row(r), base); });
    });
  };
  switch (f) {
    case Activation::identity:
      rows_loop([&](std::int64_t r, float* o, auto base) {
        const float* g = d_y.row(r);
#pragma omp simd
        for (std::int64_t c = 0; c < n; ++c) o[c] = base(o + c) + g[c];
      });
      return;
    case Activation::tanh:
      if (y.defined()) {
        rows_loop([&](std::int64_t r, float* o, auto base) {
          const float* yp = y.row(r);
          const float* g = d_y.row(r);
#pragma omp simd
          for (std::int64_t c = 0; c < n; ++c) o[c] = base(o + c) + (1.0f - yp[c]) * (1.0f + yp[c]) * g[c];
        });
      } else if (accumulate) {
        run_tanh_rows<kTanhBwdFromX>(x, d_y, d_x);
      } else {
        run_tanh_rows<kTanhBwdFromXSet>(x, d_y, d_x);
      }
      return;
    case Activation::tanhshrink:
      if (accumulate)
        run_tanh_rows<kShrinkBwd>(x, d_y, d_x);
      else
        run_tanh_rows<kShrinkBwdSet>(x, d_y, d_x);
      return;
    case Activation::leaky_relu:
    case Activation::relu: {
      // Sign of the input; for both, y > 0 iff x > 0 (slope >= 0 for leaky
      // ReLU), so y serves when x is not given.
      const Tensor& s = x.defined() ? x : y;
      const float neg = f == Activation::relu ? 0.0f : slope;
      // dy times a selected constant, as in activation_forward (vectorises; same values).
      rows_loop([&](std::int64_t r, float* o, auto base) {
        const float* sp = s.row(r);
        const float* g = d_y.row(r);
        const float k = neg;
#pragma omp simd
        for (std::int64_t c = 0; c < n; ++c) o[c] = base(o + c) + g[c] * (sp[c] > 0.0f ? 1.0f : k);
      });
      return;
    }
  }
  GATCORE_CHECK(false, "activation_backward: unknown activation ", static_cast<int>(f));
}

// ---- linear combinations -------------------------------------------------------------

void axpby(float alpha, const Tensor& a, float beta, const Tensor& b, const Tensor& y) {
  check_cpu_f32(a, "axpby: a");
  check_arg(b, a.rows(), a.cols(), "axpby: b");
  check_arg(y, a.rows(), a.cols(), "axpby: y");
  const std::int64_t n = a.cols();
  for_each_row(a.rows(), n, [&](std::int64_t r) {
    const float* ap = a.row(r);
    const float* bp = b.row(r);
    float* yp = y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) yp[c] = alpha * ap[c] + beta * bp[c];
  });
}

void axpy(float alpha, const Tensor& x, const Tensor& y) {
  check_cpu_f32(x, "axpy: x");
  check_arg(y, x.rows(), x.cols(), "axpy: y");
  const std::int64_t n = x.cols();
  for_each_row(x.rows(), n, [&](std::int64_t r) {
    const float* xp = x.row(r);
    float* yp = y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) yp[c] += alpha * xp[c];
  });
}

void mul(const Tensor& a, const Tensor& b, const Tensor& y) {
  check_cpu_f32(a, "mul: a");
  check_arg(b, a.rows(), a.cols(), "mul: b");
  check_arg(y, a.rows(), a.cols(), "mul: y");
  const std::int64_t n = a.cols();
  for_each_row(a.rows(), n, [&](std::int64_t r) {
    const float* ap = a.row(r);
    const float* bp = b.row(r);
    float* yp = y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) yp[c] = ap[c] * bp[c];
  });
}

void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a) {
  check_cpu_f32(b, "mul_accumulate: b");
  check_arg(d_y, b.rows(), b.cols(), "mul_accumulate: d_y");
  if (!d_a.defined()) return;
  check_arg(d_a, b.rows(), b.cols(), "mul_accumulate: d_a");
  const std::int64_t n = b.cols();
  for_each_row(b.rows(), n, [&](std::int64_t r) {
    const float* bp = b.row(r);
    const float* g = d_y.row(r);
    float* o = d_a.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) o[c] += bp[c] * g[c];
  });
}

void add_row_bias(const Tensor& bias, const Tensor& y) {
  check_cpu_f32(y, "add_row_bias: y");
  check_arg(bias, 1, y.cols(), "add_row_bias: bias");
  const std::int64_t n = y.cols();
  const float* bp = bias.data();
  for_each_row(y.rows(), n, [&](std::int64_t r) {
    float* yp = y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) yp[c] += bp[c];
  });
}

void bias_activation_rows(const Tensor& bias, Activation f, const Tensor& lin, const Tensor& y, std::int64_t r0,
                          std::int64_t r1) {
  check_cpu_f32(lin, "bias_activation_rows: lin");
  const std::int64_t n = lin.cols();
  if (bias.defined()) check_arg(bias, 1, n, "bias_activation_rows: bias");
  GATCORE_CHECK(f == Activation::identity || f == Activation::tanh || f == Activation::tanhshrink,
                "bias_activation_rows: activation ", activation_name(f), " (identity, tanh or tanhshrink only)");
  if (y.defined()) check_arg(y, lin.rows(), n, "bias_activation_rows: y");
  GATCORE_CHECK(f == Activation::identity || y.defined(), "bias_activation_rows: ", activation_name(f),
                " needs an output");
  GATCORE_CHECK(0 <= r0 && r0 <= r1 && r1 <= lin.rows(), "bias_activation_rows: rows [", r0, ", ", r1,
                ") outside the ", lin.rows(), " rows");
  const float* bp = bias.defined() ? bias.data() : nullptr;
  const TanhRowFn fn = f == Activation::tanh ? tanh_row_fn<kTanhFwd>()
                       : f == Activation::tanhshrink ? tanh_row_fn<kShrinkFwd>()
                                                     : nullptr;
  const bool copy = f == Activation::identity && y.defined() && !(y.data() == lin.data() && y.ld() == lin.ld());
  for (std::int64_t r = r0; r < r1; ++r) {
    float* lp = lin.row(r);
    if (bp) {
#pragma omp simd
      for (std::int64_t c = 0; c < n; ++c) lp[c] += bp[c];
    }
    if (fn)
      fn(lp, nullptr, y.row(r), n);
    else if (copy)
      std::memmove(y.row(r), lp, n * sizeof(float));
  }
}

// ---- reductions ------------------------------------------------------------------

void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias) {
  check_cpu_f32(d_y, "column_sums_accumulate: d_y");
  if (!d_bias.defined()) return;
  check_arg(d_bias, 1, d_y.cols(), "column_sums_accumulate: d_bias");
  const std::int64_t n = d_y.cols();
  const std::vector<double> s = detail::column_sums(d_y.rows(), n, [&](std::int64_t r, double* acc) {
    const float* g = d_y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) acc[c] += static_cast<double>(g[c]);
  });
  float* o = d_bias.data();
  for (std::int64_t c = 0; c < n; ++c) o[c] += static_cast<float>(s[c]);
}

double sum_all(const Tensor& x) {
  check_cpu_f32(x, "sum_all: x");
  const std::int64_t n = x.cols();
  const std::vector<double> s = detail::column_sums(x.rows(), 1, [&](std::int64_t r, double* acc) {
    const float* p = x.row(r);
    double t = 0.0;
#pragma omp simd reduction(+ : t)
    for (std::int64_t c = 0; c < n; ++c) t += static_cast<double>(p[c]);
    acc[0] += t;
  });
  return s[0];
}

void fill(const Tensor& y, float value) {
  check_cpu_f32(y, "fill: y");
  const std::int64_t n = y.cols();
  for_each_row(y.rows(), n, [&](std::int64_t r) {
    float* p = y.row(r);
    std::fill(p, p + n, value);
  });
}

}  // namespace gatcore::cpu
