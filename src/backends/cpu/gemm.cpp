// GEMM: the packed AVX-512 kernel of gemm_packed_avx512.cpp on AVX-512
// CPUs, Eigen otherwise.
//
// SIMD: Eigen picks its SIMD code at compile time and the library is built
// without -march flags, so Eigen is compiled three times: here for the
// baseline (SSE2), and in gemm_avx2.cpp / gemm_avx512.cpp with those targets
// enabled; gemm() picks one from cpu::simd_level(). Each build renames the
// Eigen namespace, so no template instantiation is shared between builds (or
// with other code of the program that uses Eigen).
//
// Threads: Eigen's own OpenMP GEMM is not deterministic across thread counts
// (its k-blocking depends on the number of threads, and a row's micro-kernel
// path depends on where the per-thread split falls), so the builds are
// compiled with EIGEN_DONT_PARALLELIZE and gemm() threads itself: C is cut
// into fixed tiles (independent of the thread count), each tile is one serial
// product (Eigen's or the packed kernel's), and the tiles are spread over the
// OpenMP threads. Every element of C is then computed the same way whatever
// the thread count.
#include "src/backends/cpu/gemm.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <string>

#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"

#include "src/backends/cpu/gemm_eigen_target_begin.inc"
#define EIGEN_DONT_PARALLELIZE 1
#define Eigen gatcore_eigen_baseline
#include <Eigen/Core>
#define GATCORE_GEMM_FN gemm_eigen_baseline
#define GATCORE_GEMM_ISA_FN gemm_eigen_isa_baseline
#include "src/backends/cpu/gemm_eigen_impl.inc"
#undef GATCORE_GEMM_FN
#undef GATCORE_GEMM_ISA_FN
#undef Eigen

namespace gatcore::cpu {

using detail::views_overlap;

namespace {
// Tile of C per serial Eigen call. Large enough that re-packing the panels of
// A and B per tile costs < 1% of the product, small enough to give 2 threads
// several tiles on the layer shapes of DenseGATs (n ~ 10^4 rows, 64..512 columns).
#ifndef GATCORE_GEMM_TILE_M  // (overridable for tuning experiments)
#define GATCORE_GEMM_TILE_M 512
#endif
#ifndef GATCORE_GEMM_TILE_N
#define GATCORE_GEMM_TILE_N 512
#endif
constexpr std::int64_t kTileM = GATCORE_GEMM_TILE_M;
constexpr std::int64_t kTileN = GATCORE_GEMM_TILE_N;
// When C is a single tile (e.g. a weight gradient X^T dY, k = nodes), k is
// split into min(8, k / 1000) chunks whose partial products (8 * 512 * 512
// floats = 8 MiB at most) are summed in chunk order.
constexpr std::int64_t kSplitKBelowTiles = 2;
constexpr std::int64_t kSplitKMinChunk = 1000;
constexpr std::int64_t kSplitKMax = 8;
// ... and the partials are at most 8 MiB (binds only for the larger bf16 tiles).
constexpr std::int64_t kSplitKMaxPartialFloats = std::int64_t(2) << 20;
// bf16 tiles: 1024 x 1024. Each tile converts its op(A) rows and op(B)
// columns to bf16 (weights and activations change every step), one
// conversion per tile_m tile_n / (tile_m + tile_n) multiply-adds: 1024 x 1024
// halves the share of 512 x 512 (measured one thread, 24576 x 1088 x 1024:
// see bench/RESULTS.md).
#ifndef GATCORE_GEMM_TILE_BF16  // (overridable for tuning experiments)
#define GATCORE_GEMM_TILE_BF16 1024
#endif
constexpr std::int64_t kTileBf16 = GATCORE_GEMM_TILE_BF16;
// Below this many flops one thread does all tiles (same result, less overhead).
constexpr double kParallelMinFlops = 4.0e6;

// GATCORE_GEMM=eigen: Eigen's AVX-512 product instead of the packed kernel
// (read once; for before/after measurements).
bool eigen_requested() {
  static const bool eigen = [] {
    const char* e = std::getenv("GATCORE_GEMM");
    return e != nullptr && std::string(e) == "eigen";
  }();
  return eigen;
}
}  // namespace

bool detail::gemm_uses_packed_avx512() {
#if defined(__x86_64__) && defined(__GNUC__)
  return simd_level() == SimdLevel::avx512 && !eigen_requested();
#else
  return false;
#endif
}

void gemm(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha, float beta,
          Precision precision) {
  detail::GemmTileFn fn = &detail::gemm_eigen_baseline;
  if (precision == Precision::bf16) {
    if (bf16_supported())
      fn = [](const detail::GemmArgs& s) { detail::gemm_bf16_tile(s, true); };
    else
      fn = [](const detail::GemmArgs& s) { detail::gemm_bf16_tile(s, false); };
    return detail::gemm_tiled(A, trans_a, B, trans_b, C, alpha, beta, fn, kTileBf16, kTileBf16);
  } else {
#if defined(__x86_64__) && defined(__GNUC__)
    switch (simd_level()) {
      case SimdLevel::avx512:
        fn = eigen_requested() ? &detail::gemm_eigen_avx512 : &detail::gemm_packed_avx512;
        break;
      case SimdLevel::avx2: fn = &detail::gemm_eigen_avx2; break;
      case SimdLevel::scalar: break;
    }
#endif
  }
  detail::gemm_tiled(A, trans_a, B, trans_b, C, alpha, beta, fn, kTileM, kTileN);
}

detail::GemmTilePlan detail::gemm_tile_plan(std::int64_t m, std::int64_t n, std::int64_t k, std::int64_t tile_m,
                                            std::int64_t tile_n) {
  // The tiles of a dimension are made equal (a multiple of 16, never larger
  // than asked): a 1088-row weight gradient in 1024-row tiles was one tile of
  // 1024 rows and one of 64, so one of 2 threads did 94 % of the NeuroSkinning
  // classifier's largest product (bench/RESULTS.md item 12).
  const auto even_tile = [](std::int64_t len, std::int64_t tile) {
    const std::int64_t count = (len + tile - 1) / tile;
    return std::max<std::int64_t>(1, std::min(tile, ((len + count - 1) / count + 15) / 16 * 16));
  };
  GemmTilePlan p{};
  p.tile_m = even_tile(m, tile_m);
  p.tile_n = even_tile(n, tile_n);
  p.tiles_m = (m + p.tile_m - 1) / p.tile_m;
  p.tiles_n = (n + p.tile_n - 1) / p.tile_n;
  std::int64_t splits = 1;
  if (p.tiles_m * p.tiles_n < kSplitKBelowTiles && k >= 2 * kSplitKMinChunk)
    splits = std::max<std::int64_t>(
        1, std::min({kSplitKMax, k / kSplitKMinChunk, kSplitKMaxPartialFloats / std::max<std::int64_t>(1, m * n)}));
  // An even number of chunks where there are several: 7 chunks on 2 threads
  // left one idle for a seventh of the product.
  if (splits > 2 && splits % 2 == 1) --splits;
  p.kc = std::max<std::int64_t>(1, (k + splits - 1) / splits);
  p.splits = std::max<std::int64_t>(1, (k + p.kc - 1) / p.kc);
  return p;
}

void detail::gemm_tiled(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha,
                        float beta, GemmTileFn fn, std::int64_t tile_m, std::int64_t tile_n) {
  check_cpu_f32(A, "gemm: A");
  check_cpu_f32(B, "gemm: B");
  check_cpu_f32(C, "gemm: C");
  const std::int64_t m = trans_a ? A.cols() : A.rows();
  const std::int64_t k = trans_a ? A.rows() : A.cols();
  const std::int64_t kb = trans_b ? B.cols() : B.rows();
  const std::int64_t n = trans_b ? B.rows() : B.cols();
  GATCORE_CHECK(k == kb, "gemm: B: inner dimensions differ: op(A) is [", m, ", ", k, "] (A ", A.shape_str(),
                trans_a ? " transposed" : "", "), op(B) is [", kb, ", ", n, "] (B ", B.shape_str(),
                trans_b ? " transposed" : "", ")");
  GATCORE_CHECK(C.rows() == m && C.cols() == n, "gemm: C: expected shape [", m, ", ", n, "], got ", C.shape_str());
  GATCORE_CHECK(!views_overlap(C, A), "gemm: C ", C.shape_str(), " overlaps A ", A.shape_str(),
                " (the output must not alias an input)");
  GATCORE_CHECK(!views_overlap(C, B), "gemm: C ", C.shape_str(), " overlaps B ", B.shape_str(),
                " (the output must not alias an input)");
  if (m == 0 || n == 0) return;

  detail::GemmArgs g{A.data(), A.rows(),  A.cols(), std::max<std::int64_t>(A.ld(), 1), trans_a,
                     B.data(), B.rows(),  B.cols(), std::max<std::int64_t>(B.ld(), 1), trans_b,
                     C.data(), m,         n,        C.ld(),                            alpha,
                     beta};
  if (k == 0 || alpha == 0.0f) {
    // No product: C = beta C (beta = 0 overwrites, ignoring NaN in C).
    for (std::int64_t r = 0; r < m; ++r) {
      float* c = C.row(r);
      if (beta == 0.0f)
        std::fill(c, c + n, 0.0f);
      else
        for (std::int64_t j = 0; j < n; ++j) c[j] *= beta;
    }
    return;
  }
  // Fixed tiling of C, and a fixed split of k when C has too few tiles to
  // keep the threads busy (weight gradients X^T dY: small C, long k). Both
  // are functions of the shape only.
  const GemmTilePlan plan = gemm_tile_plan(m, n, k, tile_m, tile_n);
  tile_m = plan.tile_m;
  tile_n = plan.tile_n;
  const std::int64_t tiles_n = plan.tiles_n, tiles = plan.tiles_m * plan.tiles_n;
  const std::int64_t splits = plan.splits, kc = plan.kc;
  const double flops = 2.0 * double(m) * double(n) * double(k);

  // Split-k partials: P_s = alpha op(A)[:, ks] op(B)[ks, :], summed in order s = 0, 1, ...
  // (uninitialised: every element is written with beta = 0)
  std::unique_ptr<float[]> partial(splits > 1 ? new float[static_cast<std::size_t>(splits * m * n)] : nullptr);

  const std::int64_t tasks = tiles * splits;
#pragma omp parallel for schedule(static) if (tasks > 1 && flops >= kParallelMinFlops)
  for (std::int64_t task = 0; task < tasks; ++task) {
    const std::int64_t t = task / splits, sp = task % splits;
    const std::int64_t i0 = (t / tiles_n) * tile_m, j0 = (t % tiles_n) * tile_n;
    const std::int64_t mi = std::min(tile_m, m - i0), nj = std::min(tile_n, n - j0);
    const std::int64_t k0 = sp * kc, kk = std::min(kc, k - k0);
    detail::GemmArgs s = g;
    // Rows i0.. and columns k0.. of op(A) (transposed: columns / rows of A).
    if (trans_a) {
      s.a += k0 * g.lda + i0;
      s.a_rows = kk;
      s.a_cols = mi;
    } else {
      s.a += i0 * g.lda + k0;
      s.a_rows = mi;
      s.a_cols = kk;
    }
    // Rows k0.. and columns j0.. of op(B).
    if (trans_b) {
      s.b += j0 * g.ldb + k0;
      s.b_rows = nj;
      s.b_cols = kk;
    } else {
      s.b += k0 * g.ldb + j0;
      s.b_rows = kk;
      s.b_cols = nj;
    }
    if (splits == 1) {
      s.c += i0 * g.ldc + j0;
    } else {
      s.c = partial.get() + sp * m * n + i0 * n + j0;
      s.ldc = n;
      s.beta = 0.0f;
    }
    s.m = mi;
    s.n = nj;
    fn(s);
  }
  if (splits == 1) return;
  const float* P = partial.get();
  float* Cp = C.data();
  const std::int64_t ldc = C.ld();
#pragma omp parallel for schedule(static) if (flops >= kParallelMinFlops)
  for (std::int64_t i = 0; i < m; ++i) {
    float* c = Cp + i * ldc;
    const float* p0 = P + i * n;
    if (beta == 0.0f) {
#pragma omp simd
      for (std::int64_t j = 0; j < n; ++j) c[j] = p0[j];
    } else {
#pragma omp simd
      for (std::int64_t j = 0; j < n; ++j) c[j] = beta * c[j] + p0[j];
    }
    for (std::int64_t sp = 1; sp < splits; ++sp) {
      const float* ps = P + sp * m * n + i * n;
#pragma omp simd
      for (std::int64_t j = 0; j < n; ++j) c[j] += ps[j];
    }
  }
}

}  // namespace gatcore::cpu
