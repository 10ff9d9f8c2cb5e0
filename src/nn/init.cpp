#include "gatcore/nn/init.hpp"

#include <cmath>

namespace gatcore::nn {

float Rng::normal() {
  // Box-Muller on our own uniforms (portable).
  float u1 = uniform();
  while (u1 <= 0.f) u1 = uniform();
  const float u2 = uniform();
  return std::sqrt(-2.f * std::log(u1)) * std::cos(6.28318530718f * u2);
}

Tensor uniform_tensor(std::int64_t rows, std::int64_t cols, float bound, Rng& rng) {
  Tensor t = Tensor::empty(rows, cols);
  for (std::int64_t i = 0; i < rows; ++i)
    for (std::int64_t j = 0; j < cols; ++j) t.at(i, j) = rng.uniform(-bound, bound);
  return t;
}

Tensor init_weight(std::int64_t fan_in, std::int64_t fan_out, Init init, Rng& rng) {
  switch (init) {
    case Init::zeros: return Tensor::zeros(fan_in, fan_out);
    case Init::he: return uniform_tensor(fan_in, fan_out, std::sqrt(6.f / float(fan_in)), rng);
    case Init::glorot: break;
  }
  return uniform_tensor(fan_in, fan_out, std::sqrt(6.f / float(fan_in + fan_out)), rng);
}

}  // namespace gatcore::nn
