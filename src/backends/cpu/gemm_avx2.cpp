// Eigen GEMM built for AVX2 + FMA, chosen at run time (see gemm.cpp).
#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include "src/backends/cpu/gemm_eigen_target_begin.inc"

GATCORE_TARGET_BEGIN("avx2,fma,f16c,popcnt")
#ifndef __SSE3__
#define __SSE3__ 1
#endif
#ifndef __SSSE3__
#define __SSSE3__ 1
#endif
#ifndef __SSE4_1__
#define __SSE4_1__ 1
#endif
#ifndef __SSE4_2__
#define __SSE4_2__ 1
#endif
#ifndef __AVX__
#define __AVX__ 1
#endif
#ifndef __AVX2__
#define __AVX2__ 1
#endif
#ifndef __FMA__
#define __FMA__ 1
#endif
#ifndef __F16C__
#define __F16C__ 1
#endif
#define EIGEN_DONT_PARALLELIZE 1
#define Eigen gatcore_eigen_avx2
#include <Eigen/Core>
#define GATCORE_GEMM_FN gemm_eigen_avx2
#define GATCORE_GEMM_ISA_FN gemm_eigen_isa_avx2
#include "src/backends/cpu/gemm_eigen_impl.inc"
#undef Eigen
GATCORE_TARGET_END
#endif
