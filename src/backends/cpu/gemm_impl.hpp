#pragma once
// Internal: the Eigen GEMM compiled once per SIMD level (gemm.cpp, baseline;
// gemm_avx2.cpp; gemm_avx512.cpp), selected at run time by gemm().
#include <cstdint>

#include "gatcore/tensor.hpp"

namespace gatcore::cpu::detail {

struct GemmArgs {
  const float* a;
  std::int64_t a_rows, a_cols, lda;  // stored shape of A (before op)
  bool trans_a;
  const float* b;
  std::int64_t b_rows, b_cols, ldb;
  bool trans_b;
  float* c;
  std::int64_t m, n, ldc;
  float alpha, beta;
};

// Own packed AVX-512 kernel (gemm_packed_avx512.cpp), the AVX-512 path;
// GATCORE_GEMM=eigen selects Eigen's AVX-512 build instead (for comparison).
void gemm_packed_avx512(const GemmArgs& g);
// Whether gemm() runs gemm_packed_avx512 (AVX-512 level, GATCORE_GEMM not
// "eigen"): gemm_prepacked() follows the same choice, so its fp32 products
// equal gemm()'s bitwise.
bool gemm_uses_packed_avx512();
// The same kernel with op(B) packed once ahead (gemm_prepacked.cpp): the
// packed size in floats of a [k, n] op(B), the packing (g's B, k and n; A and
// C unused), and the product with `packed` in place of per-call packing. C
// rows may be a subset (g.m, g.a, g.c for a row range); g.n is B's full width.
std::int64_t prepacked_size_avx512(std::int64_t k, std::int64_t n);
void prepack_b_avx512(const GemmArgs& g, float* dst);
void gemm_prepacked_avx512(const GemmArgs& g, const float* packed);
void gemm_eigen_baseline(const GemmArgs& g);
// One tile of the bf16 product (gemm_bf16_train.cpp): the VDPBF16PS kernel
// when `hardware` (AVX512_BF16 CPUs only), else its scalar emulation.
void gemm_bf16_tile(const GemmArgs& g, bool hardware);
// gemm()'s checks, fixed tiling and threading around a serial tile product
// (gemm() picks `tile` and the tile size from the precision and the CPU).
using GemmTileFn = void (*)(const GemmArgs&);
// How gemm_tiled cuts C [m, n] (k deep) for at most `tile_m` x `tile_n`
// tiles: equal tiles per dimension (a multiple of 16), and a split of k into
// an even number of chunks where C has a single tile. A function of the shape
// only, so the result does not depend on the thread count.
struct GemmTilePlan {
  std::int64_t tile_m, tile_n, tiles_m, tiles_n, splits, kc;
};
GemmTilePlan gemm_tile_plan(std::int64_t m, std::int64_t n, std::int64_t k, std::int64_t tile_m, std::int64_t tile_n);
void gemm_tiled(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha,
                float beta, GemmTileFn tile, std::int64_t tile_m, std::int64_t tile_n);
// Defined only on x86-64 builds (gemm_avx2.cpp / gemm_avx512.cpp).
void gemm_eigen_avx2(const GemmArgs& g);
void gemm_eigen_avx512(const GemmArgs& g);
// The SIMD instruction set each Eigen build vectorises with: "AVX512+FMA",
// "AVX2+FMA", "AVX", "SSE2" or "none".
const char* gemm_eigen_isa_baseline();
const char* gemm_eigen_isa_avx2();
const char* gemm_eigen_isa_avx512();

}  // namespace gatcore::cpu::detail
