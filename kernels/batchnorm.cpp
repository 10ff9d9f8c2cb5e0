// BatchNorm1d over the rows of x [n, C]. Column statistics are accumulated in
// double over fixed row blocks (deterministic for any thread count), two-pass
// (mean, then centred second moment) for stability; the elementwise parts
// are float, row-parallel.
//
// gamma / beta may be undefined (no affine transform: gamma = 1, beta = 0);
// save_mean / save_invstd and running stats may be undefined (not saved /
// not updated).
#include "kernels/batchnorm.hpp"

#include <cmath>
#include <vector>

#include "kernels/nn_detail.hpp"

namespace gatcore::cpu {

namespace {

using detail::check_arg;
using detail::check_optional;
using detail::for_each_row;

// Per-column float parameters; `p` may be undefined (default value).
std::vector<float> column_params(const Tensor& p, std::int64_t C, float dflt) {
  std::vector<float> v(static_cast<std::size_t>(C), dflt);
  if (p.defined()) {
    const float* d = p.data();
    for (std::int64_t c = 0; c < C; ++c) v[c] = d[c];
  }
  return v;
}

// y = ((x - mean_hi) - mean_lo) * scale + shift, per column. The mean is
// split into two floats (hi + lo ~ the double mean) so that data far from 0
// (e.g. 1000 +- 1) is centred without the rounding error of a float mean:
// x - mean_hi is exact when x is close to the mean.
void affine_columns(const Tensor& x, const std::vector<float>& mean_hi, const std::vector<float>& mean_lo,
                    const std::vector<float>& scale, const std::vector<float>& shift, const Tensor& y) {
  const std::int64_t C = x.cols();
  const float* mh = mean_hi.data();
  const float* ml = mean_lo.data();
  const float* s = scale.data();
  const float* b = shift.data();
  for_each_row(x.rows(), C, [&](std::int64_t r) {
    const float* xp = x.row(r);
    float* yp = y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) yp[c] = ((xp[c] - mh[c]) - ml[c]) * s[c] + b[c];
  });
}

}  // namespace

void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                             const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd,
                             const Tensor& running_mean, const Tensor& running_var) {
  check_cpu_f32(x, "batchnorm_train_forward: x");
  const std::int64_t n = x.rows(), C = x.cols();
  check_optional(gamma, 1, C, "batchnorm_train_forward: gamma");
  check_optional(beta, 1, C, "batchnorm_train_forward: beta");
  check_arg(y, n, C, "batchnorm_train_forward: y");
  check_optional(save_mean, 1, C, "batchnorm_train_forward: save_mean");
  check_optional(save_invstd, 1, C, "batchnorm_train_forward: save_invstd");
  check_optional(running_mean, 1, C, "batchnorm_train_forward: running_mean");
  check_optional(running_var, 1, C, "batchnorm_train_forward: running_var");
  GATCORE_CHECK(eps >= 0.0f && std::isfinite(eps), "batchnorm_train_forward: eps: must be finite and >= 0, got ",
                eps);
  GATCORE_CHECK(momentum >= 0.0f && momentum <= 1.0f, "batchnorm_train_forward: momentum: must be in [0, 1], got ",
                momentum);
  GATCORE_CHECK(n >= 2, "batchnorm_train_forward: x: training needs more than 1 row per channel, got shape ",
                x.shape_str());

  // Pass 1: mean.
  const std::vector<double> sum = detail::column_sums(n, C, [&](std::int64_t r, double* acc) {
    const float* xp = x.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) acc[c] += static_cast<double>(xp[c]);
  });
  std::vector<double> mean(static_cast<std::size_t>(C));
  for (std::int64_t c = 0; c < C; ++c) mean[c] = sum[c] / static_cast<double>(n);
  // Pass 2: centred second moment.
  const double* md = mean.data();
  const std::vector<double> sq = detail::column_sums(n, C, [&](std::int64_t r, double* acc) {
    const float* xp = x.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) {
      const double d = static_cast<double>(xp[c]) - md[c];
      acc[c] += d * d;
    }
  });

  const std::vector<float> g = column_params(gamma, C, 1.0f), b = column_params(beta, C, 0.0f);
  std::vector<float> mean_f(static_cast<std::size_t>(C)), mean_lo(static_cast<std::size_t>(C));
  std::vector<float> scale(static_cast<std::size_t>(C));
  std::vector<float> invstd_f(static_cast<std::size_t>(C));
  for (std::int64_t c = 0; c < C; ++c) {
    const double var = sq[c] / static_cast<double>(n);  // biased
    GATCORE_CHECK(var + static_cast<double>(eps) > 0.0, "batchnorm_train_forward: x: column ", c,
                  " is constant and eps is 0 (division by zero)");
    const double invstd = 1.0 / std::sqrt(var + static_cast<double>(eps));
    mean_f[c] = static_cast<float>(mean[c]);
    mean_lo[c] = static_cast<float>(mean[c] - static_cast<double>(mean_f[c]));
    invstd_f[c] = static_cast<float>(invstd);
    scale[c] = static_cast<float>(invstd * static_cast<double>(g[c]));
  }
  affine_columns(x, mean_f, mean_lo, scale, b, y);

  if (save_mean.defined())
    for (std::int64_t c = 0; c < C; ++c) save_mean.data()[c] = mean_f[c];
  if (save_invstd.defined())
    for (std::int64_t c = 0; c < C; ++c) save_invstd.data()[c] = invstd_f[c];
  const double m = momentum;
  if (running_mean.defined()) {
    float* rm = running_mean.data();
    for (std::int64_t c = 0; c < C; ++c) rm[c] = static_cast<float>((1.0 - m) * rm[c] + m * mean[c]);
  }
  if (running_var.defined()) {
    float* rv = running_var.data();
    const double unbias = static_cast<double>(n) / static_cast<double>(n - 1);
    for (std::int64_t c = 0; c < C; ++c)
      rv[c] = static_cast<float>((1.0 - m) * rv[c] + m * (sq[c] / static_cast<double>(n)) * unbias);
  }
}

void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& running_mean,
                            const Tensor& running_var, float eps, const Tensor& y) {
  check_cpu_f32(x, "batchnorm_eval_forward: x");
  const std::int64_t n = x.rows(), C = x.cols();
  check_optional(gamma, 1, C, "batchnorm_eval_forward: gamma");
  check_optional(beta, 1, C, "batchnorm_eval_forward: beta");
  check_arg(running_mean, 1, C, "batchnorm_eval_forward: running_mean");
  check_arg(running_var, 1, C, "batchnorm_eval_forward: running_var");
  check_arg(y, n, C, "batchnorm_eval_forward: y");
  const std::vector<float> g = column_params(gamma, C, 1.0f), b = column_params(beta, C, 0.0f);
  const std::vector<float> rm = column_params(running_mean, C, 0.0f), rv = column_params(running_var, C, 1.0f);
  std::vector<float> scale(static_cast<std::size_t>(C));
  for (std::int64_t c = 0; c < C; ++c) {
    const double v = static_cast<double>(rv[c]) + static_cast<double>(eps);
    GATCORE_CHECK(v > 0.0 && std::isfinite(v), "batchnorm_eval_forward: running_var: running_var + eps must be > 0, got ",
                  rv[c], " + ", eps, " at column ", c);
    scale[c] = static_cast<float>(static_cast<double>(g[c]) / std::sqrt(v));
  }
  affine_columns(x, rm, std::vector<float>(static_cast<std::size_t>(C), 0.0f), scale, b, y);
}

void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                              const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                              const Tensor& d_gamma, const Tensor& d_beta) {
  check_cpu_f32(x, "batchnorm_train_backward: x");
  const std::int64_t n = x.rows(), C = x.cols();
  check_optional(gamma, 1, C, "batchnorm_train_backward: gamma");
  check_arg(save_mean, 1, C, "batchnorm_train_backward: save_mean");
  check_arg(save_invstd, 1, C, "batchnorm_train_backward: save_invstd");
  check_arg(d_y, n, C, "batchnorm_train_backward: d_y");
  const bool want_x = check_optional(d_x, n, C, "batchnorm_train_backward: d_x");
  const bool want_g = check_optional(d_gamma, 1, C, "batchnorm_train_backward: d_gamma");
  const bool want_b = check_optional(d_beta, 1, C, "batchnorm_train_backward: d_beta");
  if (!want_x && !want_g && !want_b) return;
  if (n == 0) return;

  const float* mean = save_mean.data();
  const float* invstd = save_invstd.data();
  // sums[c] = Σ dy, sums[C + c] = Σ dy * xhat  (double, deterministic blocks)
  const std::vector<double> sums = detail::column_sums(n, 2 * C, [&](std::int64_t r, double* acc) {
    const float* xp = x.row(r);
    const float* g = d_y.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) {
      const double xhat = (static_cast<double>(xp[c]) - mean[c]) * invstd[c];
      acc[c] += g[c];
      acc[C + c] += static_cast<double>(g[c]) * xhat;
    }
  });
  if (want_b) {
    float* o = d_beta.data();
    for (std::int64_t c = 0; c < C; ++c) o[c] += static_cast<float>(sums[c]);
  }
  if (want_g) {
    float* o = d_gamma.data();
    for (std::int64_t c = 0; c < C; ++c) o[c] += static_cast<float>(sums[C + c]);
  }
  if (!want_x) return;
  // d_x = gamma invstd (dy - Σdy/n - xhat Σ(dy xhat)/n)
  const std::vector<float> gm = column_params(gamma, C, 1.0f);
  std::vector<float> k_mean(static_cast<std::size_t>(C)), k_proj(static_cast<std::size_t>(C));
  std::vector<float> k_scale(static_cast<std::size_t>(C));
  for (std::int64_t c = 0; c < C; ++c) {
    k_mean[c] = static_cast<float>(sums[c] / static_cast<double>(n));
    k_proj[c] = static_cast<float>(sums[C + c] / static_cast<double>(n));
    k_scale[c] = static_cast<float>(static_cast<double>(gm[c]) * invstd[c]);
  }
  const float* km = k_mean.data();
  const float* kp = k_proj.data();
  const float* ks = k_scale.data();
  for_each_row(n, C, [&](std::int64_t r) {
    const float* xp = x.row(r);
    const float* g = d_y.row(r);
    float* o = d_x.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) {
      const float xhat = (xp[c] - mean[c]) * invstd[c];
      o[c] += ks[c] * (g[c] - km[c] - xhat * kp[c]);
    }
  });
}

void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                             const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                             const Tensor& d_gamma, const Tensor& d_beta) {
  check_cpu_f32(x, "batchnorm_eval_backward: x");
  const std::int64_t n = x.rows(), C = x.cols();
  check_optional(gamma, 1, C, "batchnorm_eval_backward: gamma");
  check_arg(running_mean, 1, C, "batchnorm_eval_backward: running_mean");
  check_arg(running_var, 1, C, "batchnorm_eval_backward: running_var");
  check_arg(d_y, n, C, "batchnorm_eval_backward: d_y");
  const bool want_x = check_optional(d_x, n, C, "batchnorm_eval_backward: d_x");
  const bool want_g = check_optional(d_gamma, 1, C, "batchnorm_eval_backward: d_gamma");
  const bool want_b = check_optional(d_beta, 1, C, "batchnorm_eval_backward: d_beta");
  if (!want_x && !want_g && !want_b) return;
  const std::vector<float> gm = column_params(gamma, C, 1.0f);
  const float* rm = running_mean.data();
  const float* rv = running_var.data();
  std::vector<float> invstd(static_cast<std::size_t>(C)), scale(static_cast<std::size_t>(C));
  for (std::int64_t c = 0; c < C; ++c) {
    const double v = static_cast<double>(rv[c]) + static_cast<double>(eps);
    GATCORE_CHECK(v > 0.0 && std::isfinite(v), "batchnorm_eval_backward: running_var: running_var + eps must be > 0, got ",
                  rv[c], " + ", eps, " at column ", c);
    invstd[c] = static_cast<float>(1.0 / std::sqrt(v));
    scale[c] = static_cast<float>(static_cast<double>(gm[c]) / std::sqrt(v));
  }
  const float* is = invstd.data();
  if (want_g || want_b) {
    const std::vector<double> sums = detail::column_sums(n, 2 * C, [&](std::int64_t r, double* acc) {
      const float* xp = x.row(r);
      const float* g = d_y.row(r);
#pragma omp simd
      for (std::int64_t c = 0; c < C; ++c) {
        acc[c] += g[c];
        acc[C + c] += static_cast<double>(g[c]) * ((static_cast<double>(xp[c]) - rm[c]) * is[c]);
      }
    });
    if (want_b)
      for (std::int64_t c = 0; c < C; ++c) d_beta.data()[c] += static_cast<float>(sums[c]);
    if (want_g)
      for (std::int64_t c = 0; c < C; ++c) d_gamma.data()[c] += static_cast<float>(sums[C + c]);
  }
  if (!want_x) return;
  const float* s = scale.data();
  for_each_row(n, C, [&](std::int64_t r) {
    const float* g = d_y.row(r);
    float* o = d_x.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) o[c] += g[c] * s[c];
  });
}

}  // namespace gatcore::cpu
