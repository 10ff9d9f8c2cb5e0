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
#include "src/backends/cpu/batchnorm.hpp"

#include <cmath>
#include <type_traits>
#include <vector>

#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"
#include "src/backends/cpu/target_region.hpp"

namespace gatcore::cpu {

namespace isa_baseline {
#include "src/backends/cpu/batchnorm_impl.inc"
}  // namespace isa_baseline

#if defined(__x86_64__) && defined(__GNUC__)
GATCORE_TARGET_BEGIN2("avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,prefer-vector-width=512", "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma")
namespace isa_avx512 {
#include "src/backends/cpu/batchnorm_impl.inc"
}  // namespace isa_avx512
GATCORE_TARGET_END
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

void batchnorm_affine_forward(const Tensor& x, const Tensor& mean, const Tensor& scale, const Tensor& shift,
                              const Tensor& y) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_affine_forward : isa_baseline::batchnorm_affine_forward)(x, mean, scale,
                                                                                                     shift, y);
}

void batchnorm_eval_scale(const Tensor& gamma, const Tensor& running_var, float eps, const Tensor& scale) {
  check_cpu_f32(running_var, "batchnorm_eval_scale: running_var");
  const std::int64_t C = running_var.cols();
  GATCORE_CHECK(running_var.rows() == 1 && scale.rows() == 1 && scale.cols() == C &&
                    (!gamma.defined() || (gamma.rows() == 1 && gamma.cols() == C)),
                "batchnorm_eval_scale: gamma, running_var and scale must be [1, ", C, "]");
  for (std::int64_t c = 0; c < C; ++c) {
    const double v = static_cast<double>(running_var.at(0, c)) + static_cast<double>(eps);
    GATCORE_CHECK(v > 0.0 && std::isfinite(v), "batchnorm_eval_scale: running_var + eps must be > 0, got ",
                  running_var.at(0, c), " + ", eps, " at column ", c);
    const double g = gamma.defined() ? static_cast<double>(gamma.at(0, c)) : 1.0;
    scale.at(0, c) = static_cast<float>(g / std::sqrt(v));
  }
}

void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                              const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                              const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across,
                              bool accumulate_dx) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_train_backward : isa_baseline::batchnorm_train_backward)(
      x, gamma, save_mean, save_invstd, d_y, d_x, d_gamma, d_beta, across, accumulate_dx);
}

void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                             const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                             const Tensor& d_gamma, const Tensor& d_beta) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_eval_backward : isa_baseline::batchnorm_eval_backward)(
      x, gamma, running_mean, running_var, eps, d_y, d_x, d_gamma, d_beta);
}

void batchnorm_act_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                                 Activation f, float slope, const Tensor& y, const Tensor& save_mean,
                                 const Tensor& save_invstd, const Tensor& save_affine, const Tensor& running_mean,
                                 const Tensor& running_var, const SumAcross& across) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_act_train_forward : isa_baseline::batchnorm_act_train_forward)(
      x, gamma, beta, eps, momentum, f, slope, y, save_mean, save_invstd, save_affine, running_mean, running_var,
      across);
}

void batchnorm_act_apply(const Tensor& x, const Tensor& beta, Activation f, float slope, const Tensor& save_mean,
                         const Tensor& save_affine, const Tensor& y) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_act_apply : isa_baseline::batchnorm_act_apply)(x, beta, f, slope,
                                                                                           save_mean, save_affine, y);
}

void batchnorm_act_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& beta, Activation f, float slope,
                                  const Tensor& save_mean, const Tensor& save_invstd, const Tensor& save_affine,
                                  const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta,
                                  const SumAcross& across, bool accumulate_dx) {
  (GATCORE_BN_AVX512 ? isa_avx512::batchnorm_act_train_backward : isa_baseline::batchnorm_act_train_backward)(
      x, gamma, beta, f, slope, save_mean, save_invstd, save_affine, d_y, d_x, d_gamma, d_beta, across,
      accumulate_dx);
}

}  // namespace gatcore::cpu
