// Eigen GEMM built for AVX-512 (F/BW/VL/DQ) + FMA, chosen at run time (see gemm.cpp).
#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include "src/backends/cpu/gemm_eigen_target_begin.inc"

// GCC 12 reports the _mm512_undefined_* idiom in its own AVX-512 headers
// (used by Eigen) as -Wmaybe-uninitialized; it is a false positive.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
GATCORE_TARGET_BEGIN2("avx512f,avx512bw,avx512vl,avx512dq,avx512cd,avx2,fma,f16c,popcnt,prefer-vector-width=512", "avx512f,avx512bw,avx512vl,avx512dq,avx512cd,avx2,fma,f16c,popcnt")
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
#ifndef __AVX512F__
#define __AVX512F__ 1
#endif
#ifndef __AVX512BW__
#define __AVX512BW__ 1
#endif
#ifndef __AVX512VL__
#define __AVX512VL__ 1
#endif
#ifndef __AVX512DQ__
#define __AVX512DQ__ 1
#endif
#ifndef __AVX512CD__
#define __AVX512CD__ 1
#endif
#define EIGEN_DONT_PARALLELIZE 1
#define Eigen gatcore_eigen_avx512
#include <Eigen/Core>
#define GATCORE_GEMM_FN gemm_eigen_avx512
#define GATCORE_GEMM_ISA_FN gemm_eigen_isa_avx512
#include "src/backends/cpu/gemm_eigen_impl.inc"
#undef Eigen
GATCORE_TARGET_END
#endif
