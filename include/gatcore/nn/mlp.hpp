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
  // Layers from `from` on (from = 1: the caller ran the first layer itself).
  Var forward(const Var& x, bool training, Rng& rng, std::size_t from = 0);
  void fold();
  std::int64_t out_width(std::int64_t in) const;
};

}  // namespace gatcore::nn
