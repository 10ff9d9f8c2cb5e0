#include "gatcore/nn/dropout.hpp"
#include "gatcore/backend.hpp"

namespace gatcore::nn {

Var Dropout::forward(const Var& x, bool training, Rng& rng) const {
  if (!training || p <= 0.f) return x;
  GATCORE_CHECK(p < 1.f, "Dropout: p must be < 1, got ", p);
  Tensor mask = Tensor::empty(x.rows(), x.cols());
  const float keep = 1.f / (1.f - p);
  for (std::int64_t i = 0; i < x.rows(); ++i)
    for (std::int64_t j = 0; j < x.cols(); ++j) mask.at(i, j) = rng.uniform() < p ? 0.f : keep;
  // Drawn on the host (same stream on every device), uploaded explicitly.
  return mul(x, Var(to(mask, x.device())));
}

}  // namespace gatcore::nn
