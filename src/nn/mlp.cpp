#include "gatcore/nn/mlp.hpp"

namespace gatcore::nn {

DenseLayer::DenseLayer(const Scope& s, std::int64_t in, std::int64_t out, const DenseLayerOptions& o, Rng& rng)
    : opt(o) {
  // He init for ReLU-family activations, Glorot otherwise.
  Init init = o.init;
  if (init == Init::glorot && (o.act == Activation::relu || o.act == Activation::leaky_relu)) init = Init::he;
  lin = Linear(s.sub("lin"), in, out, rng, init, true);
  if (o.batch_norm) bn = BatchNorm1d(s.sub("bn"), out);
}

Var DenseLayer::forward(const Var& x, bool training, Rng& rng, const Var& into) {
  GATCORE_CHECK(!(training && folded), "DenseLayer: BatchNorm was folded for inference; cannot train");
  const bool use_bn = opt.batch_norm && !folded;
  const bool has_act = opt.act != Activation::identity;
  const bool has_drop = training && opt.dropout > 0.f;
  // `into` goes to the last op of the chain.
  return after_linear(linear(x, lin.W, lin.b, (!use_bn && !has_act && !has_drop) ? into : Var{}), training, rng,
                      into);
}

Var DenseLayer::after_linear(const Var& z, bool training, Rng& rng, const Var& into) {
  GATCORE_CHECK(!(training && folded), "DenseLayer: BatchNorm was folded for inference; cannot train");
  const bool use_bn = opt.batch_norm && !folded;
  const bool has_act = opt.act != Activation::identity;
  const bool has_drop = training && opt.dropout > 0.f;
  if (!use_bn && !has_act && !has_drop) return into.defined() && z.impl() != into.impl() ? copy_into(z, into) : z;
  Var y = z;
  if (use_bn) y = bn.forward(y, training, (!has_act && !has_drop) ? into : Var{});
  if (has_act) y = activation(opt.act, y, opt.slope, has_drop ? Var{} : into);
  if (has_drop) {
    y = Dropout{opt.dropout}.forward(y, training, rng);
    if (into.defined()) y = copy_into(y, into);
  }
  return y;
}

void DenseLayer::fold() {
  if (!opt.batch_norm || folded) return;
  fold_batch_norm(lin, bn);
  folded = true;
}

Mlp::Mlp(const Scope& s, std::int64_t in, const std::vector<std::int64_t>& hidden, std::int64_t out,
         const DenseLayerOptions& opt, Rng& rng) {
  std::int64_t w = in;
  for (std::size_t k = 0; k < hidden.size(); ++k) {
    layers.emplace_back(s.sub(std::int64_t(k)), w, hidden[k], opt, rng);
    w = hidden[k];
  }
  if (out > 0) {
    last = Linear(s.sub(std::int64_t(hidden.size())), w, out, rng, Init::glorot, true);
    has_last = true;
  }
}

Var Mlp::forward(const Var& x, bool training, Rng& rng, std::size_t from) {
  GATCORE_CHECK(from <= layers.size(), "Mlp::forward: from = ", from, " but the MLP has ", layers.size(),
                " hidden layers");
  Var y = x;
  for (std::size_t k = from; k < layers.size(); ++k) y = layers[k].forward(y, training, rng);
  if (has_last) y = last.forward(y);
  return y;
}

void Mlp::fold() {
  for (auto& l : layers) l.fold();
}

std::int64_t Mlp::out_width(std::int64_t in) const {
  if (has_last) return last.out;
  return layers.empty() ? in : layers.back().out();
}

}  // namespace gatcore::nn
