#include "gatcore/nn/batchnorm.hpp"

#include <cmath>

namespace gatcore::nn {

BatchNorm1d::BatchNorm1d(const Scope& s, std::int64_t channels, float momentum, float eps) {
  gamma = s.param("gamma", Tensor::full(1, channels, 1.f));
  beta = s.param("beta", Tensor::zeros(1, channels));
  state.running_mean = Tensor::zeros(1, channels);
  state.running_var = Tensor::full(1, channels, 1.f);
  state.momentum = momentum;
  state.eps = eps;
  s.buffer("running_mean", state.running_mean);
  s.buffer("running_var", state.running_var);
}

void fold_batch_norm(Linear& lin, const BatchNorm1d& bn) {
  const std::int64_t C = lin.out;
  GATCORE_CHECK(bn.gamma.cols() == C, "fold_batch_norm: BatchNorm has ", bn.gamma.cols(), " channels, Linear ", C);
  const Tensor& W = lin.W.value();
  std::vector<double> s(std::size_t(C), 0.0), shift(std::size_t(C), 0.0);
  for (std::int64_t c = 0; c < C; ++c) {
    s[c] = double(bn.gamma.value().at(0, c)) / std::sqrt(double(bn.state.running_var.at(0, c)) + bn.state.eps);
    const double b = lin.b.defined() ? lin.b.value().at(0, c) : 0.0;
    shift[c] = (b - bn.state.running_mean.at(0, c)) * s[c] + bn.beta.value().at(0, c);
  }
  for (std::int64_t i = 0; i < W.rows(); ++i)
    for (std::int64_t c = 0; c < C; ++c) W.at(i, c) = float(double(W.at(i, c)) * s[c]);
  W.bump_version();
  if (!lin.b.defined()) lin.b = Var::parameter(Tensor::zeros(1, C), lin.W.name() + ".folded_b");
  for (std::int64_t c = 0; c < C; ++c) lin.b.value().at(0, c) = float(shift[c]);
  lin.b.value().bump_version();
}

}  // namespace gatcore::nn
