#pragma once
// Internal: the Eigen GEMM compiled once per SIMD level (gemm.cpp, baseline;
// gemm_avx2.cpp; gemm_avx512.cpp), selected at run time by gemm().
#include <cstdint>

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
void gemm_eigen_baseline(const GemmArgs& g);
// Defined only on x86-64 builds (gemm_avx2.cpp / gemm_avx512.cpp).
void gemm_eigen_avx2(const GemmArgs& g);
void gemm_eigen_avx512(const GemmArgs& g);
// The SIMD instruction set each Eigen build vectorises with: "AVX512+FMA",
// "AVX2+FMA", "AVX", "SSE2" or "none".
const char* gemm_eigen_isa_baseline();
const char* gemm_eigen_isa_avx2();
const char* gemm_eigen_isa_avx512();

}  // namespace gatcore::cpu::detail
