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
  Backend& be = backend(x.device());
  Var both(be.empty(n, kf + self_width));
  if (self_width > 0) {
    // Both streams' products as one: x·[W | W_self] + [0 | b_self]. The
    // self stream alone is an 8-column product (a quarter of the GEMM's rate
    // forward, a narrow weight gradient backward: 11 % of the DenseGATs
    // training step for 6 % of its multiply-adds); the [in, 72] weight copy
    // and its gradient split cost a pass over in × 72 floats.
    Var bias = self.b.defined() ? concat({Var(be.zeros(1, kf)), self.b}) : Var{};
    Var z = linear(x, concat({W, self.W}), bias);
    gat_additive(g, z.cols_slice(0, kf), att_dst, att_src, opt.slope, both.cols_slice(0, kf));
    copy_into(z.cols_slice(kf, kf + self_width), both.cols_slice(kf, kf + self_width));
  } else {
    gat_additive(g, linear(x, W, Var{}), att_dst, att_src, opt.slope, both.cols_slice(0, kf));
  }
  if (!opt.batch_norm) return tanhshrink(both, into);
  return bn.forward(tanhshrink(both), training, into);
}

}  // namespace gatcore::nn
