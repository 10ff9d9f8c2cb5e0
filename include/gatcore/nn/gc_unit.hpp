#pragma once
// The NeuroSkinning graph-convolution unit:
//   conv   = σ(multi-head dot-product attention over N(i)) of h = x·C  [n, K·F']
//   pooled = mean of conv over the J geodesically nearest vertices     [n, K·F']
//   out    = x ++ conv ++ pooled                                       [n, F + 2·K·F']
// All three parts are written into one output buffer (copy_into / into=).
// Parameters "C" [F, K·F'], "C_b". Logits are scaled by 1/sqrt(F') and σ is
// LeakyReLU(0.1) (the paper leaves both open). pool = false drops `pooled`
// (the "w/o graph pooling" ablation).
#include "gatcore/nn/linear.hpp"

namespace gatcore::nn {

struct GcUnitOptions {
  int heads = 4, head_dim = 64, pool_size = 16;
  bool pool = true;
  float slope = 0.1f;
};

struct GcUnit {
  Linear C;
  GcUnitOptions opt;
  std::int64_t in = 0;

  GcUnit() = default;
  GcUnit(const Scope& s, std::int64_t in, const GcUnitOptions& opt, Rng& rng);
  std::int64_t out() const {
    const std::int64_t c = std::int64_t(opt.heads) * opt.head_dim;
    return in + c + (opt.pool ? c : 0);
  }
  // nbr: row i = the pool_size nearest vertices of i (required if opt.pool).
  Var forward(const GraphPtr& g, const GraphPtr& nbr, const Var& x) const;
  // The same on a buffer [n, out()] whose columns [0, in) already hold x
  // (written there by the previous unit): writes the rest, returns buf. A
  // chain of units then shares one buffer (each unit's input is the prefix of
  // the next one's) instead of copying its input forward.
  Var forward_into(const GraphPtr& g, const GraphPtr& nbr, const Var& buf) const;
};

}  // namespace gatcore::nn
