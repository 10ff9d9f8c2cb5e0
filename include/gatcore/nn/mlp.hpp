#pragma once
// Dense layers: Linear → [BatchNorm1d] → activation → [dropout], and MLPs of
// them. A DenseLayer's BatchNorm can be folded into its Linear for inference
// (fold()): afterwards eval forward skips the BatchNorm, training throws.
#include <vector>

#include "gatcore/activation.hpp"
#include "gatcore/nn/batchnorm.hpp"
#include "gatcore/nn/dropout.hpp"

namespace gatcore::nn {

struct DenseLayerOptions {
  Activation act = Activation::relu;
  float slope = 0.01f;  // LeakyReLU
  bool batch_norm = true;
  float dropout = 0.f;
  Init init = Init::glorot;
};

struct DenseLayer {
  Linear lin;  // "lin"
  BatchNorm1d bn;  // "bn"
  DenseLayerOptions opt;
  bool folded = false;

  DenseLayer() = default;
  DenseLayer(const Scope& s, std::int64_t in, std::int64_t out, const DenseLayerOptions& opt, Rng& rng);
  Var forward(const Var& x, bool training, Rng& rng, const Var& into = {});
  // The part after the Linear ([BatchNorm] → activation → [dropout]) on its
  // output z, for callers that compute the product themselves.
  Var after_linear(const Var& z, bool training, Rng& rng, const Var& into = {});
  // True when this layer's [BatchNorm] → activation can run fused with the
  // next layer's Linear (fused_with_next): training with BatchNorm, an
  // activation the fused kernels have (identity, relu, leaky_relu), no dropout.
  bool fuses_with_next(bool training) const;
  // after_linear(z) followed by next's Linear, with the activation never kept
  // (ops.hpp batch_norm_act_linear): the next layer's Linear output.
  Var fused_with_next(const Var& z, const Linear& next);
  void fold();
  std::int64_t out() const { return lin.out; }
};

// Hidden layers with `opt`, then (if out > 0) a plain Linear output layer.
struct Mlp {
  std::vector<DenseLayer> layers;  // "0", "1", ...
  Linear last;                     // "<hidden count>", present if has_last
  bool has_last = false;

  Mlp() = default;
  Mlp(const Scope& s, std::int64_t in, const std::vector<std::int64_t>& hidden, std::int64_t out,
      const DenseLayerOptions& opt, Rng& rng);
  Var forward(const Var& x, bool training, Rng& rng);
  // The layers from `k` on, given layer k's Linear output z (the caller
  // computed that product itself). While training, each layer's BatchNorm →
  // activation runs fused with the next Linear (DenseLayer::fused_with_next),
  // so the MLP keeps one [n, width] tensor per layer for backward.
  Var forward_after_linear(const Var& z, bool training, Rng& rng, std::size_t k);
  void fold();
  std::int64_t out_width(std::int64_t in) const;
};

}  // namespace gatcore::nn
