#include "gatcore/nn/gat_block.hpp"

#include <cmath>

#include "gatcore/backend.hpp"

namespace gatcore::nn {

GatBlock::GatBlock(const Scope& s, std::int64_t in, const GatBlockOptions& o, Rng& rng) : opt(o) {
  const std::int64_t kf = std::int64_t(o.heads) * o.head_dim;
  GATCORE_CHECK(o.heads > 0 && o.head_dim > 0, "GatBlock ", s.prefix, ": heads and head_dim must be positive");
  self_width = std::int64_t(std::lround(double(o.beta) * double(kf)));
  W = s.param("W", init_weight(in, kf, Init::glorot, rng));
  const float ab = std::sqrt(6.f / float(o.head_dim + 1));
  att_dst = s.param("att_dst", uniform_tensor(o.heads, o.head_dim, ab, rng));
  att_src = s.param("att_src", uniform_tensor(o.heads, o.head_dim, ab, rng));
  if (self_width > 0) self = Linear(s.sub("self"), in, self_width, rng, Init::glorot, true);
  if (o.batch_norm) bn = BatchNorm1d(s.sub("bn"), kf + self_width);
}

Var GatBlock::forward(const GraphPtr& g, const Var& x, bool training, const Var& into) {
  const std::int64_t kf = std::int64_t(opt.heads) * opt.head_dim;
  const std::int64_t n = x.rows();
  // Scratch [aggregation | self stream]: both streams write their slot.
  Var both(backend(x.device()).empty(n, kf + self_width));
  gat_additive(g, linear(x, W, Var{}), att_dst, att_src, opt.slope, both.cols_slice(0, kf));
  if (self_width > 0) self.forward(x, both.cols_slice(kf, kf + self_width));
  if (!opt.batch_norm) return tanhshrink(both, into);
  return bn.forward(tanhshrink(both), training, into);
}

}  // namespace gatcore::nn
