#include "gatcore/nn/gc_unit.hpp"

#include <cmath>

#include "gatcore/backend.hpp"

namespace gatcore::nn {

GcUnit::GcUnit(const Scope& s, std::int64_t in_, const GcUnitOptions& o, Rng& rng) : opt(o), in(in_) {
  C = Linear(s.sub("C"), in, std::int64_t(o.heads) * o.head_dim, rng, Init::glorot, true);
}

Var GcUnit::forward(const GraphPtr& g, const GraphPtr& nbr, const Var& x) const {
  Var out(backend(x.device()).empty(x.rows(), this->out()));
  copy_into(x, out.cols_slice(0, in));
  return forward_into(g, nbr, out);
}

Var GcUnit::forward_into(const GraphPtr& g, const GraphPtr& nbr, const Var& buf) const {
  GATCORE_CHECK(buf.cols() == out(), "GcUnit: buffer has ", buf.cols(), " columns, expected ", out());
  const std::int64_t c = std::int64_t(opt.heads) * opt.head_dim;
  const Var x = buf.cols_slice(0, in);
  Var conv_slot = buf.cols_slice(in, in + c);
  Var att = gat_dot(g, C.forward(x), opt.heads, 1.f / std::sqrt(float(opt.head_dim)));
  leaky_relu(att, opt.slope, conv_slot);
  if (opt.pool) {
    GATCORE_CHECK(nbr != nullptr, "GcUnit: pooling needs a neighbour graph (pool size ", opt.pool_size, ")");
    neighbour_mean(nbr, conv_slot, buf.cols_slice(in + c, in + 2 * c));
  }
  return buf;
}

}  // namespace gatcore::nn
