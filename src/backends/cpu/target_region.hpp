#pragma once
// Portable "compile the following functions for ISA X" regions, so the same
// source builds with GCC and clang (clang ignores `#pragma GCC target`; it has
// `#pragma clang attribute` instead, which attaches target(...) to every
// function declared in the region, template instantiations and lambdas
// included).
//   GATCORE_TARGET_BEGIN("avx2,fma") ... GATCORE_TARGET_END
// GATCORE_TARGET_BEGIN2(gcc_isa, clang_isa): different strings per compiler,
// for GCC's "prefer-vector-width=512", a tuning hint with no clang
// target-attribute spelling (clang builds go without it).
#define GATCORE_PRAGMA(x) _Pragma(#x)
#if defined(__clang__)
#define GATCORE_TARGET_BEGIN(isa) GATCORE_PRAGMA(clang attribute push(__attribute__((target(isa))), apply_to = function))
#define GATCORE_TARGET_BEGIN2(gcc_isa, clang_isa) GATCORE_TARGET_BEGIN(clang_isa)
#define GATCORE_TARGET_END _Pragma("clang attribute pop")
#else
#define GATCORE_TARGET_BEGIN(isa) _Pragma("GCC push_options") GATCORE_PRAGMA(GCC target(isa))
#define GATCORE_TARGET_BEGIN2(gcc_isa, clang_isa) GATCORE_TARGET_BEGIN(gcc_isa)
#define GATCORE_TARGET_END _Pragma("GCC pop_options")
#endif
