// Losses reduced in double over fixed row blocks (deterministic for any
// thread count); gradients elementwise, row-parallel.
#include "src/backends/cpu/loss.hpp"

#include <cmath>

#include "src/backends/cpu/nn_detail.hpp"

namespace gatcore::cpu {

using detail::check_arg;
using detail::for_each_row;

double mse_forward(const Tensor& pred, const Tensor& target) {
  check_cpu_f32(pred, "mse_forward: pred");
  check_arg(target, pred.rows(), pred.cols(), "mse_forward: target");
  GATCORE_CHECK(pred.numel() > 0, "mse_forward: pred: empty tensor ", pred.shape_str(), " has no mean");
  const std::int64_t n = pred.cols();
  const std::vector<double> s = detail::column_sums(pred.rows(), 1, [&](std::int64_t r, double* acc) {
    const float* p = pred.row(r);
    const float* t = target.row(r);
    double a = 0.0;
#pragma omp simd reduction(+ : a)
    for (std::int64_t c = 0; c < n; ++c) {
      const double d = static_cast<double>(p[c]) - static_cast<double>(t[c]);
      a += d * d;
    }
    acc[0] += a;
  });
  return s[0] / static_cast<double>(pred.numel());
}

void mse_backward(const Tensor& pred, const Tensor& target, float scale, const Tensor& d_pred) {
  check_cpu_f32(pred, "mse_backward: pred");
  check_arg(target, pred.rows(), pred.cols(), "mse_backward: target");
  if (!d_pred.defined()) return;
  check_arg(d_pred, pred.rows(), pred.cols(), "mse_backward: d_pred");
  if (pred.numel() == 0) return;
  const float k = static_cast<float>(2.0 * static_cast<double>(scale) / static_cast<double>(pred.numel()));
  const std::int64_t n = pred.cols();
  for_each_row(pred.rows(), n, [&](std::int64_t r) {
    const float* p = pred.row(r);
    const float* t = target.row(r);
    float* o = d_pred.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) o[c] += k * (p[c] - t[c]);
  });
}

double kl_div_forward(const Tensor& pred, const Tensor& target, float eps) {
  check_cpu_f32(pred, "kl_div_forward: pred");
  check_arg(target, pred.rows(), pred.cols(), "kl_div_forward: target");
  GATCORE_CHECK(eps > 0.0f && std::isfinite(eps), "kl_div_forward: eps: must be finite and > 0, got ", eps);
  GATCORE_CHECK(pred.rows() > 0, "kl_div_forward: pred: empty tensor ", pred.shape_str(), " has no mean over rows");
  const std::int64_t n = pred.cols();
  const double e = eps;
  // acc[0]: the sum; acc[1]: count of invalid (negative or NaN) targets.
  const std::vector<double> s = detail::column_sums(pred.rows(), 2, [&](std::int64_t r, double* acc) {
    const float* p = pred.row(r);
    const float* t = target.row(r);
    double a = 0.0, bad = 0.0;
    for (std::int64_t c = 0; c < n; ++c) {
      const double tc = t[c];
      if (tc > 0.0) {
        const double pc = static_cast<double>(p[c]);
        a += tc * (std::log(tc) - std::log(pc > e ? pc : (pc != pc ? pc : e)));
      } else if (!(tc == 0.0)) {
        bad += 1.0;
      }
    }
    acc[0] += a;
    acc[1] += bad;
  });
  if (s[1] != 0.0) {
    // Name the first offending entry.
    for (std::int64_t r = 0; r < target.rows(); ++r)
      for (std::int64_t c = 0; c < n; ++c) {
        const float tc = target.at(r, c);
        GATCORE_CHECK(tc >= 0.0f, "kl_div_forward: target: entries must be >= 0 (a distribution), got ", tc,
                      " at row ", r, ", column ", c);
      }
  }
  return s[0] / static_cast<double>(pred.rows());
}

void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, float scale, const Tensor& d_pred) {
  check_cpu_f32(pred, "kl_div_backward: pred");
  check_arg(target, pred.rows(), pred.cols(), "kl_div_backward: target");
  GATCORE_CHECK(eps > 0.0f && std::isfinite(eps), "kl_div_backward: eps: must be finite and > 0, got ", eps);
  if (!d_pred.defined()) return;
  check_arg(d_pred, pred.rows(), pred.cols(), "kl_div_backward: d_pred");
  if (pred.rows() == 0) return;
  const float k = static_cast<float>(-static_cast<double>(scale) / static_cast<double>(pred.rows()));
  const std::int64_t n = pred.cols();
  for_each_row(pred.rows(), n, [&](std::int64_t r) {
    const float* p = pred.row(r);
    const float* t = target.row(r);
    float* o = d_pred.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) {
      const float pc = p[c] > eps ? p[c] : (p[c] != p[c] ? p[c] : eps);
      o[c] += k * (t[c] / pc);
    }
  });
}

}  // namespace gatcore::cpu
