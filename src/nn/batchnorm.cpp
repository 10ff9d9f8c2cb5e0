#include "gatcore/nn/batchnorm.hpp"

#include <cmath>

#include "gatcore/backend.hpp"

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
  // Computed on host copies; a device model gets the results uploaded.
  const Device dev = lin.W.device();
  const Tensor W = dev == Device::cpu ? lin.W.value() : to(lin.W.value(), Device::cpu);
  const Tensor gamma = to(bn.gamma.value(), Device::cpu), beta = to(bn.beta.value(), Device::cpu);
  const Tensor rmean = to(bn.state.running_mean, Device::cpu), rvar = to(bn.state.running_var, Device::cpu);
  const Tensor lb = lin.b.defined() ? to(lin.b.value(), Device::cpu) : Tensor{};
  std::vector<double> s(std::size_t(C), 0.0), shift(std::size_t(C), 0.0);
  for (std::int64_t c = 0; c < C; ++c) {
    s[c] = double(gamma.at(0, c)) / std::sqrt(double(rvar.at(0, c)) + bn.state.eps);
    const double b = lb.defined() ? lb.at(0, c) : 0.0;
    shift[c] = (b - rmean.at(0, c)) * s[c] + beta.at(0, c);
  }
  for (std::int64_t i = 0; i < W.rows(); ++i)
    for (std::int64_t c = 0; c < C; ++c) W.at(i, c) = float(double(W.at(i, c)) * s[c]);
  if (dev != Device::cpu) backend(dev).copy(to(W, dev), lin.W.value());
  lin.W.value().bump_version();
  Tensor bh = Tensor::empty(1, C);
  for (std::int64_t c = 0; c < C; ++c) bh.at(0, c) = float(shift[c]);
  if (!lin.b.defined()) lin.b = Var::parameter(backend(dev).zeros(1, C), lin.W.name() + ".folded_b");
  if (dev == Device::cpu) lin.b.value().copy_from_(bh);
  else backend(dev).copy(to(bh, dev), lin.b.value());
  lin.b.value().bump_version();
}

}  // namespace gatcore::nn
