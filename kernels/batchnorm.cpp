// BatchNorm1d over the rows of x [n, C]. Column statistics are accumulated in
// double over fixed row blocks (deterministic for any thread count), two-pass
// (mean, then centred second moment) for stability; the elementwise parts
// are float, row-parallel.
//
// gamma / beta may be undefined (no affine transform: gamma = 1, beta = 0);
// save_mean / save_invstd and running stats may be undefined (not saved /
// not updated).
//
// SIMD: the library is built for baseline x86-64, where these loops (double
// statistics) vectorise two lanes wide; the same bodies are compiled a second
// time for AVX-512 (batchnorm_impl.inc in namespace isa_avx512) and picked by
// cpu::simd_level(). The statistics are per-column sums in a fixed row order,
// so the width does not change them; the elementwise float parts may round
// differently (FMA contraction), like every other kernel across SIMD levels.
#include "kernels/batchnorm.hpp"

#include <cmath>
#include <vector>

#include "kernels/nn_detail.hpp"
#include "kernels/simd.hpp"

namespace gatcore::cpu {

namespace isa_baseline {
#include "kernels/batchnorm_impl.inc"
}  // namespace isa_baseline

#if defined(__x86_64__) && defined(__GNUC__)
#pragma GCC push_options
#pragma GCC target("avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,prefer-vector-width=512")
namespace isa_avx512 {
#include "kernels/batchnorm_impl.inc"
}  // namespace isa_avx512
#pragma GCC pop_options
#define GATCORE_BN_AVX512 (simd_level() == SimdLevel::avx512)
#else
#define GATCORE_BN_AVX512 false
namespace isa_avx512 = isa_baseline;
#endif

void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                             const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd,
                             const Tensor& running_mean, const Tensor& running_var, const SumAcross& across) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_train_forward : isa_baseline::batchnorm_train_forward)(
      x, gamma, beta, eps, momentum, y, save_mean, save_invstd, running_mean, running_var, across);
}

void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& running_mean,
                            const Tensor& running_var, float eps, const Tensor& y) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_eval_forward : isa_baseline::batchnorm_eval_forward)(
      x, gamma, beta, running_mean, running_var, eps, y);
}

void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                              const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                              const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_train_backward : isa_baseline::batchnorm_train_backward)(
      x, gamma, save_mean, save_invstd, d_y, d_x, d_gamma, d_beta, across);
}

void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                             const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                             const Tensor& d_gamma, const Tensor& d_beta) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_eval_backward : isa_baseline::batchnorm_eval_backward)(
      x, gamma, running_mean, running_var, eps, d_y, d_x, d_gamma, d_beta);
}

}  // namespace gatcore::cpu
