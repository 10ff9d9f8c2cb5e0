#pragma once
// The GAT block of DenseGATs: K heads × F additive-attention aggregation
// (LeakyReLU 0.2 logits, softmax over N(i)) ++ a self-reinforced Linear
// stream of width βKF, then tanhshrink and BatchNorm. Both streams write into
// one scratch tensor (no concat copy); the BatchNorm writes straight into the
// caller's slot (`into`, e.g. the block's slice of the dense buffer).
// Parameters: "W" [in, KF], "att_dst"/"att_src" [K, F], "self.W"/"self.b",
// "bn.*".
#include "gatcore/nn/batchnorm.hpp"

namespace gatcore::nn {

struct GatBlockOptions {
  int heads = 8, head_dim = 8;
  float beta = 0.125f;  // self stream width = round(beta*K*F); 0 disables it
  float slope = 0.2f;
  bool batch_norm = true;
};

struct GatBlock {
  Var W, att_dst, att_src;
  Linear self;
  BatchNorm1d bn;
  GatBlockOptions opt;
  std::int64_t self_width = 0;

  GatBlock() = default;
  GatBlock(const Scope& s, std::int64_t in, const GatBlockOptions& opt, Rng& rng);
  std::int64_t out() const { return std::int64_t(opt.heads) * opt.head_dim + self_width; }
  Var forward(const GraphPtr& g, const Var& x, bool training, const Var& into = {});
};

}  // namespace gatcore::nn
