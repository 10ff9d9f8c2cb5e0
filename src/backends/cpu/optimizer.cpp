#include "src/backends/cpu/optimizer.hpp"

#include <cmath>

namespace gatcore::cpu {

void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr, float beta1,
                 float beta2, float eps, float weight_decay, long step) {
  check_cpu_f32(param, "adam_update: param");
  check_shape(grad, param.rows(), param.cols(), "adam_update: grad");
  check_shape(m, param.rows(), param.cols(), "adam_update: m");
  check_shape(v, param.rows(), param.cols(), "adam_update: v");
  GATCORE_CHECK(step >= 1, "adam_update: step must be >= 1, got ", step);
  const float c1 = 1.0f / (1.0f - std::pow(beta1, static_cast<float>(step)));
  const float c2 = 1.0f / (1.0f - std::pow(beta2, static_cast<float>(step)));
  const std::int64_t rows = param.rows(), cols = param.cols();
#pragma omp parallel for schedule(static) if (rows * cols > 65536)
  for (std::int64_t r = 0; r < rows; ++r) {
    float* p = param.row(r);
    const float* g = grad.row(r);
    float* mr = m.row(r);
    float* vr = v.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < cols; ++c) {
      const float gc = g[c] + weight_decay * p[c];
      mr[c] = beta1 * mr[c] + (1.0f - beta1) * gc;
      vr[c] = beta2 * vr[c] + (1.0f - beta2) * gc * gc;
      p[c] -= lr * (mr[c] * c1) / (std::sqrt(vr[c] * c2) + eps);
    }
  }
}

}  // namespace gatcore::cpu
