#pragma once
// Internal helpers shared by the graph-attention kernels (projection, edge
// softmax, aggregation, fused GAT): argument checks, scratch buffers, the
// OpenMP row partitioning, a vectorised exp, and the per-ISA vector types.
//
// Code layout. Every kernel family (.cpp) holds two kinds of implementation:
//  - a generic one for any H, F written against a lane-vector type `V`
//    (VScalar: 1 lane, VAvx2: 8 lanes, VAvx512: 16 lanes, tails masked).
//    Heads are processed one after another, the feature loop is innermost
//    and vectorised. With VScalar it is the portable fallback.
//  - a fast one for H = 8, F = 8 written against `Ops88` (Ops88Avx2: one
//    ymm per head; Ops88Avx512: one zmm per two heads), where the 8 heads of
//    a row are one register and the row of 64 features stays in registers.
// The family's implementation lives in attn_*_impl.inc and is
// included once per ISA inside an ATTN_BEGIN_* / ATTN_END region (a GCC
// target pragma), so the same source is compiled for each instruction set
// and dispatched on cpu::simd_level() at run time. The library itself is
// built without -march flags.
// GCC 12 reports its own _mm512_undefined_* placeholders inside the AVX-512
// intrinsics as "may be used uninitialized" (GCC PR 105593); silence that for
// the intrinsic headers only (include this header before anything else that
// pulls in <immintrin.h>).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "gatcore/error.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/simd.hpp"
#include "src/backends/cpu/target_region.hpp"

#define ATTN_BEGIN_AVX2 GATCORE_TARGET_BEGIN("avx2,fma")
#define ATTN_BEGIN_AVX512 GATCORE_TARGET_BEGIN("avx512f,avx512bw,avx512vl,avx2,fma")
#define ATTN_END GATCORE_TARGET_END

namespace gatcore::cpu::attn {

// ---------------------------------------------------------------------------
// Argument checks (O(1); messages name the kernel, the argument and shapes).

struct Dim {
  const char* name;  // e.g. "E", "H", "H*F"; nullptr: just the number
  std::int64_t value;  // < 0: any
};

[[noreturn]] inline void fail_shape(const char* fn, const char* arg, const Tensor& t, Dim r, Dim c) {
  auto part = [](Dim d) {
    if (d.value < 0) return std::string(d.name ? d.name : "*");
    if (d.name) return detail::cat(d.name, "=", d.value);
    return detail::cat(d.value);
  };
  throw InvalidArgument(
      detail::cat(fn, ": ", arg, ": expected shape [", part(r), ", ", part(c), "], got ", t.shape_str()));
}

inline void check_arg(const char* fn, const char* arg, const Tensor& t, Dim r, Dim c) {
  if (!t.defined()) throw InvalidArgument(detail::cat(fn, ": ", arg, ": tensor is undefined"));
  if (t.device() != Device::cpu)
    throw InvalidArgument(detail::cat(fn, ": ", arg, ": tensor lives on ", device_name(t.device()),
                                      ", this kernel runs on the CPU"));
  if (t.dtype() != DType::f32) throw InvalidArgument(detail::cat(fn, ": ", arg, ": expected float32, got int32"));
  if (t.storage()->host == nullptr)
    throw InvalidArgument(detail::cat(fn, ": ", arg, ": tensor is not host-addressable"));
  if ((r.value >= 0 && t.rows() != r.value) || (c.value >= 0 && t.cols() != c.value)) fail_shape(fn, arg, t, r, c);
}

// Optional (gradient) outputs: undefined means "not wanted".
inline bool check_opt(const char* fn, const char* arg, const Tensor& t, Dim r, Dim c) {
  if (!t.defined()) return false;
  check_arg(fn, arg, t, r, c);
  return true;
}

// Raw view of a CSR graph with its transpose, checked for consistent sizes.
struct GraphView {
  std::int64_t n = 0, E = 0;
  const std::int64_t* indptr = nullptr;
  const std::int32_t* indices = nullptr;
  const std::int64_t* out_ptr = nullptr;
  const std::int32_t* out_dst = nullptr;
  const std::int32_t* out_edge = nullptr;
};

inline GraphView graph_view(const char* fn, const CsrGraph& g) {
  const std::int64_t n = g.num_nodes;
  GATCORE_CHECK(n >= 0, fn, ": graph: negative num_nodes ", n);
  GATCORE_CHECK(static_cast<std::int64_t>(g.indptr.size()) == n + 1, fn, ": graph: indptr has ", g.indptr.size(),
                " entries, expected num_nodes + 1 = ", n + 1);
  const std::int64_t E = static_cast<std::int64_t>(g.indices.size());
  GATCORE_CHECK(g.indptr[0] == 0 && g.indptr[n] == E, fn, ": graph: indptr spans [", g.indptr[0], ", ",
                g.indptr[n], "] but indices has ", E, " entries");
  GATCORE_CHECK(static_cast<std::int64_t>(g.out_ptr.size()) == n + 1 &&
                    static_cast<std::int64_t>(g.out_dst.size()) == E &&
                    static_cast<std::int64_t>(g.out_edge.size()) == E && g.out_ptr[0] == 0 && g.out_ptr[n] == E,
                fn, ": graph: transpose arrays inconsistent (out_ptr ", g.out_ptr.size(), " entries, out_dst ",
                g.out_dst.size(), ", out_edge ", g.out_edge.size(), ") for ", n, " nodes and ", E, " edges");
  GATCORE_CHECK(E <= INT32_MAX, fn, ": graph: ", E, " edges exceed the int32 edge-id range");
  GraphView v;
  v.n = n;
  v.E = E;
  v.indptr = g.indptr.data();
  v.indices = g.indices.data();
  v.out_ptr = g.out_ptr.data();
  v.out_dst = g.out_dst.data();
  v.out_edge = g.out_edge.data();
  return v;
}

// A strided float matrix as raw pointer + row stride (null when undefined).
struct Mat {
  float* p = nullptr;
  std::int64_t ld = 0;
  float* row(std::int64_t r) const { return p + r * ld; }
  explicit operator bool() const { return p != nullptr; }
};
inline Mat mat(const Tensor& t) {
  if (!t.defined()) return {};
  return {t.data(), t.ld()};
}

// ---------------------------------------------------------------------------
// Scratch: grow-only, 64-byte aligned, one set of slots per thread.

inline float* scratch(std::size_t n, int slot) {
  struct Buf {
    float* p = nullptr;
    std::size_t cap = 0;
    ~Buf() { std::free(p); }
  };
  thread_local Buf bufs[4];
  Buf& b = bufs[slot];
  if (b.cap < n) {
    std::size_t cap = std::max<std::size_t>(n, b.cap + b.cap / 2);
    cap = (cap + 15) / 16 * 16;
    void* p = std::aligned_alloc(64, cap * sizeof(float));
    if (!p) throw Error(detail::cat("gatcore: out of memory allocating ", cap * sizeof(float), " bytes of scratch"));
    std::free(b.p);
    b.p = static_cast<float*>(p);
    b.cap = cap;
  }
  return b.p;
}

// ---------------------------------------------------------------------------
// OpenMP over rows with edge-balanced ranges (balanced_rows). Work below
// kParallelMin runs on the calling thread. Results never depend on the
// thread count: every output row is produced by exactly one thread, in a
// fixed order.

inline constexpr std::int64_t kParallelMin = 2048;

template <class Fn>
inline void parallel_rows(const GraphView& g, const std::int64_t* ptr, Fn&& fn) {
  const std::span<const std::int64_t> sp(ptr, static_cast<std::size_t>(g.n + 1));
#pragma omp parallel if (g.E + g.n >= kParallelMin)
  {
    const RowRange r = balanced_rows(sp, omp_get_thread_num(), omp_get_num_threads());
    if (r.begin < r.end) fn(r.begin, r.end);
  }
}

// Phase 1 over destination rows (indptr), barrier, phase 2 over source rows
// (the transpose, out_ptr).
template <class Fn1, class Fn2>
inline void parallel_two_phase(const GraphView& g, Fn1&& f1, Fn2&& f2) {
  const std::span<const std::int64_t> p1(g.indptr, static_cast<std::size_t>(g.n + 1));
  const std::span<const std::int64_t> p2(g.out_ptr, static_cast<std::size_t>(g.n + 1));
#pragma omp parallel if (g.E + g.n >= kParallelMin)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const RowRange r1 = balanced_rows(p1, t, nt);
    if (r1.begin < r1.end) f1(r1.begin, r1.end);
#pragma omp barrier
    const RowRange r2 = balanced_rows(p2, t, nt);
    if (r2.begin < r2.end) f2(r2.begin, r2.end);
  }
}

// Uniform-cost loops over node rows (projection): static blocks.
template <class Fn>
inline void parallel_blocks(std::int64_t nblocks, std::int64_t work, Fn&& fn) {
#pragma omp parallel for schedule(static) if (work >= kParallelMin)
  for (std::int64_t b = 0; b < nblocks; ++b) fn(b);
}

// ---------------------------------------------------------------------------
// Dispatch: pick the row function for the current SIMD level; `fixed` says
// the shape is the H = 8, F = 8 case with a register path.

template <class Fn>
inline Fn select_impl(bool fixed, Fn scalar, Fn avx2, Fn avx2_88, Fn avx512, Fn avx512_88) {
  switch (simd_level()) {
    case SimdLevel::avx512: return fixed ? avx512_88 : avx512;
    case SimdLevel::avx2: return fixed ? avx2_88 : avx2;
    case SimdLevel::scalar: break;
  }
  return scalar;
}
#define ATTN_SELECT(fixed, name)                                                                  \
  ::gatcore::cpu::attn::select_impl((fixed), &isa_scalar::name##_generic, &isa_avx2::name##_generic, \
                                    &isa_avx2::name##_88, &isa_avx512::name##_generic,              \
                                    &isa_avx512::name##_88)

// ---------------------------------------------------------------------------
// Scalar lane type (portable fallback).

struct VScalar {
  using T = float;
  static constexpr int W = 1;
  static T zero() { return 0.0f; }
  static T set1(float v) { return v; }
  static T load(const float* p) { return *p; }
  static T loadn(const float* p, int) { return *p; }
  static void store(float* p, T v) { *p = v; }
  static void storen(float* p, T v, int) { *p = v; }
  static T add(T a, T b) { return a + b; }
  static T mul(T a, T b) { return a * b; }
  static T fma(T a, T b, T c) { return a * b + c; }
  static float hsum(T v) { return v; }
};

// LeakyReLU and its derivative (x > 0 ? 1 : slope), the PyTorch convention.
inline float leaky(float x, float slope) { return x > 0.0f ? x : x * slope; }
inline float leaky_grad(float x, float d, float slope) { return x > 0.0f ? d : d * slope; }

}  // namespace gatcore::cpu::attn

// ===========================================================================
// AVX2 / FMA
ATTN_BEGIN_AVX2
namespace gatcore::cpu::attn {

// exp(x) for 8 lanes, Cephes polynomial on [-ln2/2, ln2/2], ~1 ulp relative
// error for x in [-87.3, 88]. Below ln(FLT_MIN) gives 0; above 88 gives
// exp(88) (softmax only evaluates x <= 0). NaN propagates.
static inline __m256 exp_avx2(__m256 x) {
  const __m256 lo = _mm256_set1_ps(-87.33654475f);
  const __m256 under = _mm256_cmp_ps(x, lo, _CMP_LT_OQ);
  x = _mm256_min_ps(_mm256_set1_ps(88.0f), x);
  x = _mm256_max_ps(lo, x);
  const __m256i ni = _mm256_cvtps_epi32(_mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f)));
  const __m256 n = _mm256_cvtepi32_ps(ni);
  __m256 r = _mm256_fnmadd_ps(n, _mm256_set1_ps(0.693359375f), x);
  r = _mm256_fnmadd_ps(n, _mm256_set1_ps(-2.12194440e-4f), r);
  __m256 p = _mm256_set1_ps(1.9875691500e-4f);
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.3981999507e-3f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(8.3334519073e-3f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(4.1665795894e-2f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.6666665459e-1f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(5.0000001201e-1f));
  const __m256 r2 = _mm256_mul_ps(r, r);
  __m256 y = _mm256_fmadd_ps(p, r2, r);
  y = _mm256_add_ps(y, _mm256_set1_ps(1.0f));
  const __m256i e = _mm256_slli_epi32(_mm256_add_epi32(ni, _mm256_set1_epi32(127)), 23);
  y = _mm256_mul_ps(y, _mm256_castsi256_ps(e));
  return _mm256_andnot_ps(under, y);
}

static inline __m256i tail_mask_avx2(int n) {
  return _mm256_cmpgt_epi32(_mm256_set1_epi32(n), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
}

struct VAvx2 {
  using T = __m256;
  static constexpr int W = 8;
  static T zero() { return _mm256_setzero_ps(); }
  static T set1(float v) { return _mm256_set1_ps(v); }
  static T load(const float* p) { return _mm256_loadu_ps(p); }
  static T loadn(const float* p, int n) { return _mm256_maskload_ps(p, tail_mask_avx2(n)); }
  static void store(float* p, T v) { _mm256_storeu_ps(p, v); }
  static void storen(float* p, T v, int n) { _mm256_maskstore_ps(p, tail_mask_avx2(n), v); }
  static T add(T a, T b) { return _mm256_add_ps(a, b); }
  static T mul(T a, T b) { return _mm256_mul_ps(a, b); }
  static T fma(T a, T b, T c) { return _mm256_fmadd_ps(a, b, c); }
  static float hsum(T v) {
    __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    s = _mm_add_ss(s, _mm_movehdup_ps(s));
    return _mm_cvtss_f32(s);
  }
};

// Sums of 8 vectors, lane k of the result = horizontal sum of p[k].
static inline __m256 reduce8_avx2(const __m256* p) {
  const __m256 t0 = _mm256_hadd_ps(p[0], p[1]);
  const __m256 t1 = _mm256_hadd_ps(p[2], p[3]);
  const __m256 t2 = _mm256_hadd_ps(p[4], p[5]);
  const __m256 t3 = _mm256_hadd_ps(p[6], p[7]);
  const __m256 u0 = _mm256_hadd_ps(t0, t1);  // [s0..s3 low halves | s0..s3 high halves]
  const __m256 u1 = _mm256_hadd_ps(t2, t3);
  const __m256 lo = _mm256_permute2f128_ps(u0, u1, 0x20);
  const __m256 hi = _mm256_permute2f128_ps(u0, u1, 0x31);
  return _mm256_add_ps(lo, hi);
}

// H = 8, F = 8 with one ymm per head. Heads: the 8 per-head scalars of a row
// (one ymm); Row: 64 features (8 ymm, kept in registers by the kernels).
struct Ops88Avx2 {
  using Heads = __m256;
  struct Row {
    __m256 v[8];
  };
  static Heads hload(const float* p) { return _mm256_loadu_ps(p); }
  static void hstore(float* p, Heads x) { _mm256_storeu_ps(p, x); }
  static Heads hzero() { return _mm256_setzero_ps(); }
  static Heads hset1(float v) { return _mm256_set1_ps(v); }
  static Heads hadd(Heads a, Heads b) { return _mm256_add_ps(a, b); }
  static Heads hsub(Heads a, Heads b) { return _mm256_sub_ps(a, b); }
  static Heads hmul(Heads a, Heads b) { return _mm256_mul_ps(a, b); }
  static Heads hdiv(Heads a, Heads b) { return _mm256_div_ps(a, b); }
  static Heads hmax(Heads a, Heads b) { return _mm256_max_ps(a, b); }
  static Heads hfma(Heads a, Heads b, Heads c) { return _mm256_fmadd_ps(a, b, c); }
  static Heads hexp(Heads x) { return exp_avx2(x); }
  static Heads hleaky(Heads x, float slope) {
    return _mm256_blendv_ps(_mm256_mul_ps(x, _mm256_set1_ps(slope)), x,
                            _mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_GT_OQ));
  }
  // d * (x > 0 ? 1 : slope)
  static Heads hleaky_grad(Heads x, Heads d, float slope) {
    return _mm256_blendv_ps(_mm256_mul_ps(d, _mm256_set1_ps(slope)), d,
                            _mm256_cmp_ps(x, _mm256_setzero_ps(), _CMP_GT_OQ));
  }
  static bool hany_gt(Heads a, Heads b) { return _mm256_movemask_ps(_mm256_cmp_ps(a, b, _CMP_GT_OQ)) != 0; }

  static Row rzero() {
    Row r;
    for (int k = 0; k < 8; ++k) r.v[k] = _mm256_setzero_ps();
    return r;
  }
  static Row rload(const float* p) {
    Row r;
    for (int k = 0; k < 8; ++k) r.v[k] = _mm256_loadu_ps(p + 8 * k);
    return r;
  }
  static void rstore(float* p, const Row& r) {
    for (int k = 0; k < 8; ++k) _mm256_storeu_ps(p + 8 * k, r.v[k]);
  }
  // p += r
  static void radd_store(float* p, const Row& r) {
    for (int k = 0; k < 8; ++k) _mm256_storeu_ps(p + 8 * k, _mm256_add_ps(_mm256_loadu_ps(p + 8 * k), r.v[k]));
  }
  // acc += expand(a) * x, a: 8 head scalars in memory, x: 64 features in memory
  static void rfma_mem(Row& acc, const float* a, const float* x) {
    for (int k = 0; k < 8; ++k)
      acc.v[k] = _mm256_fmadd_ps(_mm256_broadcast_ss(a + k), _mm256_loadu_ps(x + 8 * k), acc.v[k]);
  }
  static void rfma(Row& acc, Heads a, const float* x) {
    alignas(32) float t[8];
    _mm256_store_ps(t, a);
    rfma_mem(acc, t, x);
  }
  // acc += expand(a) * x with x in registers
  static void rfma_row(Row& acc, Heads a, const Row& x) {
    alignas(32) float t[8];
    _mm256_store_ps(t, a);
    for (int k = 0; k < 8; ++k) acc.v[k] = _mm256_fmadd_ps(_mm256_broadcast_ss(t + k), x.v[k], acc.v[k]);
  }
  static void rscale(Row& acc, Heads c) {
    alignas(32) float t[8];
    _mm256_store_ps(t, c);
    for (int k = 0; k < 8; ++k) acc.v[k] = _mm256_mul_ps(acc.v[k], _mm256_broadcast_ss(t + k));
  }
  static void rstore_scaled(float* p, const Row& acc, Heads c) {
    alignas(32) float t[8];
    _mm256_store_ps(t, c);
    for (int k = 0; k < 8; ++k) _mm256_storeu_ps(p + 8 * k, _mm256_mul_ps(acc.v[k], _mm256_broadcast_ss(t + k)));
  }
  // per-head dot products <x^k, y^k>
  static Heads rdot(const Row& x, const float* y) {
    __m256 p[8];
    for (int k = 0; k < 8; ++k) p[k] = _mm256_mul_ps(x.v[k], _mm256_loadu_ps(y + 8 * k));
    return reduce8_avx2(p);
  }
  static void prefetch(const float* p) {
    _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 16), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 32), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 48), _MM_HINT_T0);
  }
};

}  // namespace gatcore::cpu::attn
ATTN_END

// ===========================================================================
// AVX-512 (F, BW, VL) + FMA
ATTN_BEGIN_AVX512
namespace gatcore::cpu::attn {

// exp with the same polynomial; 2^n applied by vscalefps (correct under- and
// overflow, no masking needed).
static inline __m512 exp_avx512(__m512 x) {
  x = _mm512_max_ps(_mm512_set1_ps(-104.0f), x);
  const __m512 n = _mm512_roundscale_ps(_mm512_mul_ps(x, _mm512_set1_ps(1.44269504088896341f)),
                                        _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m512 r = _mm512_fnmadd_ps(n, _mm512_set1_ps(0.693359375f), x);
  r = _mm512_fnmadd_ps(n, _mm512_set1_ps(-2.12194440e-4f), r);
  __m512 p = _mm512_set1_ps(1.9875691500e-4f);
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.3981999507e-3f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(8.3334519073e-3f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(4.1665795894e-2f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(1.6666665459e-1f));
  p = _mm512_fmadd_ps(p, r, _mm512_set1_ps(5.0000001201e-1f));
  __m512 y = _mm512_fmadd_ps(p, _mm512_mul_ps(r, r), r);
  y = _mm512_add_ps(y, _mm512_set1_ps(1.0f));
  return _mm512_scalef_ps(y, n);
}

static inline __m256 exp_avx512vl(__m256 x) {
  x = _mm256_max_ps(_mm256_set1_ps(-104.0f), x);
  const __m256 n = _mm256_roundscale_ps(_mm256_mul_ps(x, _mm256_set1_ps(1.44269504088896341f)),
                                        _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  __m256 r = _mm256_fnmadd_ps(n, _mm256_set1_ps(0.693359375f), x);
  r = _mm256_fnmadd_ps(n, _mm256_set1_ps(-2.12194440e-4f), r);
  __m256 p = _mm256_set1_ps(1.9875691500e-4f);
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.3981999507e-3f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(8.3334519073e-3f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(4.1665795894e-2f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(1.6666665459e-1f));
  p = _mm256_fmadd_ps(p, r, _mm256_set1_ps(5.0000001201e-1f));
  __m256 y = _mm256_fmadd_ps(p, _mm256_mul_ps(r, r), r);
  y = _mm256_add_ps(y, _mm256_set1_ps(1.0f));
  return _mm256_scalef_ps(y, n);
}

struct VAvx512 {
  using T = __m512;
  static constexpr int W = 16;
  static __mmask16 m(int n) { return static_cast<__mmask16>((1u << n) - 1u); }
  static T zero() { return _mm512_setzero_ps(); }
  static T set1(float v) { return _mm512_set1_ps(v); }
  static T load(const float* p) { return _mm512_loadu_ps(p); }
  static T loadn(const float* p, int n) { return _mm512_maskz_loadu_ps(m(n), p); }
  static void store(float* p, T v) { _mm512_storeu_ps(p, v); }
  static void storen(float* p, T v, int n) { _mm512_mask_storeu_ps(p, m(n), v); }
  static T add(T a, T b) { return _mm512_add_ps(a, b); }
  static T mul(T a, T b) { return _mm512_mul_ps(a, b); }
  static T fma(T a, T b, T c) { return _mm512_fmadd_ps(a, b, c); }
  static float hsum(T v) { return _mm512_reduce_add_ps(v); }
};

// H = 8, F = 8 with one zmm per pair of heads (Row = 4 zmm); Heads stay one
// ymm of 8 lanes.
struct Ops88Avx512 {
  using Heads = __m256;
  struct Row {
    __m512 v[4];
  };
  // Lane pattern [2q x8, 2q+1 x8]: expands head scalars onto head pair q.
  static __m512i pair_idx(int q) {
    return _mm512_add_epi32(_mm512_set1_epi32(2 * q),
                            _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1));
  }
  static __m512 expand(__m512 a, int q) { return _mm512_permutexvar_ps(pair_idx(q), a); }

  static Heads hload(const float* p) { return _mm256_loadu_ps(p); }
  static void hstore(float* p, Heads x) { _mm256_storeu_ps(p, x); }
  static Heads hzero() { return _mm256_setzero_ps(); }
  static Heads hset1(float v) { return _mm256_set1_ps(v); }
  static Heads hadd(Heads a, Heads b) { return _mm256_add_ps(a, b); }
  static Heads hsub(Heads a, Heads b) { return _mm256_sub_ps(a, b); }
  static Heads hmul(Heads a, Heads b) { return _mm256_mul_ps(a, b); }
  static Heads hdiv(Heads a, Heads b) { return _mm256_div_ps(a, b); }
  static Heads hmax(Heads a, Heads b) { return _mm256_max_ps(a, b); }
  static Heads hfma(Heads a, Heads b, Heads c) { return _mm256_fmadd_ps(a, b, c); }
  static Heads hexp(Heads x) { return exp_avx512vl(x); }
  static Heads hleaky(Heads x, float slope) {
    const __mmask8 neg = _mm256_cmp_ps_mask(x, _mm256_setzero_ps(), _CMP_NGT_UQ);
    return _mm256_mask_mul_ps(x, neg, x, _mm256_set1_ps(slope));
  }
  static Heads hleaky_grad(Heads x, Heads d, float slope) {
    const __mmask8 neg = _mm256_cmp_ps_mask(x, _mm256_setzero_ps(), _CMP_NGT_UQ);
    return _mm256_mask_mul_ps(d, neg, d, _mm256_set1_ps(slope));
  }
  static bool hany_gt(Heads a, Heads b) { return _mm256_cmp_ps_mask(a, b, _CMP_GT_OQ) != 0; }

  static Row rzero() {
    Row r;
    for (int q = 0; q < 4; ++q) r.v[q] = _mm512_setzero_ps();
    return r;
  }
  static Row rload(const float* p) {
    Row r;
    for (int q = 0; q < 4; ++q) r.v[q] = _mm512_loadu_ps(p + 16 * q);
    return r;
  }
  static void rstore(float* p, const Row& r) {
    for (int q = 0; q < 4; ++q) _mm512_storeu_ps(p + 16 * q, r.v[q]);
  }
  static void radd_store(float* p, const Row& r) {
    for (int q = 0; q < 4; ++q) _mm512_storeu_ps(p + 16 * q, _mm512_add_ps(_mm512_loadu_ps(p + 16 * q), r.v[q]));
  }
  static void rfma(Row& acc, Heads a, const float* x) {
    const __m512 a5 = _mm512_zextps256_ps512(a);
    for (int q = 0; q < 4; ++q) acc.v[q] = _mm512_fmadd_ps(expand(a5, q), _mm512_loadu_ps(x + 16 * q), acc.v[q]);
  }
  static void rfma_mem(Row& acc, const float* a, const float* x) { rfma(acc, _mm256_loadu_ps(a), x); }
  static void rfma_row(Row& acc, Heads a, const Row& x) {
    const __m512 a5 = _mm512_zextps256_ps512(a);
    for (int q = 0; q < 4; ++q) acc.v[q] = _mm512_fmadd_ps(expand(a5, q), x.v[q], acc.v[q]);
  }
  static void rscale(Row& acc, Heads c) {
    const __m512 c5 = _mm512_zextps256_ps512(c);
    for (int q = 0; q < 4; ++q) acc.v[q] = _mm512_mul_ps(acc.v[q], expand(c5, q));
  }
  static void rstore_scaled(float* p, const Row& acc, Heads c) {
    const __m512 c5 = _mm512_zextps256_ps512(c);
    for (int q = 0; q < 4; ++q) _mm512_storeu_ps(p + 16 * q, _mm512_mul_ps(acc.v[q], expand(c5, q)));
  }
  // per-head dot products: 4 products [h2q | h2q+1], reduced with in-lane
  // shuffles to one ymm [h0..h7].
  static Heads rdot(const Row& x, const float* y) {
    __m512 s[4];
    for (int q = 0; q < 4; ++q) {
      const __m512 p = _mm512_mul_ps(x.v[q], _mm512_loadu_ps(y + 16 * q));
      // 128-bit lanes [a0 b0 a1 b1] -> [a0+b0, a0+b0, a1+b1, a1+b1]
      s[q] = _mm512_add_ps(p, _mm512_shuffle_f32x4(p, p, _MM_SHUFFLE(2, 3, 0, 1)));
    }
    const __m512 u01 = _mm512_mask_blend_ps(0xF0F0, s[0], s[1]);  // lanes: h0 h2 h1 h3
    const __m512 u23 = _mm512_mask_blend_ps(0xF0F0, s[2], s[3]);  // lanes: h4 h6 h5 h7
    const __m512 w = _mm512_add_ps(_mm512_shuffle_ps(u01, u23, _MM_SHUFFLE(1, 0, 1, 0)),
                                   _mm512_shuffle_ps(u01, u23, _MM_SHUFFLE(3, 2, 3, 2)));
    const __m512 t = _mm512_add_ps(w, _mm512_permute_ps(w, _MM_SHUFFLE(2, 3, 0, 1)));
    // lane L: element 4L = head of u01 lane L, element 4L+2 = head of u23 lane L
    const __m512i idx = _mm512_setr_epi32(0, 8, 4, 12, 2, 10, 6, 14, 0, 0, 0, 0, 0, 0, 0, 0);
    return _mm512_castps512_ps256(_mm512_permutexvar_ps(idx, t));
  }
  static void prefetch(const float* p) {
    _mm_prefetch(reinterpret_cast<const char*>(p), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 16), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 32), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(p + 48), _MM_HINT_T0);
  }
};

}  // namespace gatcore::cpu::attn
ATTN_END

// ===========================================================================
// Per-ISA namespaces: `V` (lane vector), `Ops88` where a fixed H=8/F=8 path
// exists, and the feature-vector helpers of attn_feat.inc.
namespace gatcore::cpu::attn::isa_scalar {
using V = VScalar;
#include "src/backends/cpu/attn_feat.inc"
}  // namespace gatcore::cpu::attn::isa_scalar

ATTN_BEGIN_AVX2
namespace gatcore::cpu::attn::isa_avx2 {
using V = VAvx2;
using Ops88 = Ops88Avx2;
#include "src/backends/cpu/attn_feat.inc"
}  // namespace gatcore::cpu::attn::isa_avx2
ATTN_END

ATTN_BEGIN_AVX512
namespace gatcore::cpu::attn::isa_avx512 {
using V = VAvx512;
using Ops88 = Ops88Avx512;
#include "src/backends/cpu/attn_feat.inc"
}  // namespace gatcore::cpu::attn::isa_avx512
ATTN_END
