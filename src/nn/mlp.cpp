#include "gatcore/nn/mlp.hpp"

namespace gatcore::nn {

namespace {
// The activations ops.hpp's fused BatchNorm ops apply.
bool fusable(Activation f) {
  return f == Activation::identity || f == Activation::relu || f == Activation::leaky_relu;
}
}  // namespace

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
  if (use_bn && has_act && training && fusable(opt.act)) {
    // One op, one saved tensor (z) instead of BatchNorm's and the activation's.
    y = batch_norm_act(z, bn.gamma, bn.beta, bn.state, opt.act, opt.slope, has_drop ? Var{} : into);
  } else {
    if (use_bn) y = bn.forward(y, training, (!has_act && !has_drop) ? into : Var{});
    if (has_act) y = activation(opt.act, y, opt.slope, has_drop ? Var{} : into);
  }
  if (has_drop) {
    y = Dropout{opt.dropout}.forward(y, training, rng);
    if (into.defined()) y = copy_into(y, into);
  }
  return y;
}

bool DenseLayer::fuses_with_next(bool training) const {
  return training && opt.batch_norm && !folded && opt.dropout == 0.f && fusable(opt.act);
}

Var DenseLayer::fused_with_next(const Var& z, const Linear& next) {
  GATCORE_CHECK(fuses_with_next(true), "DenseLayer::fused_with_next: the layer does not fuse (BatchNorm folded or "
                                       "absent, dropout, or activation ", activation_name(opt.act), ")");
  return batch_norm_act_linear(z, bn.gamma, bn.beta, bn.state, opt.act, opt.slope, next.W, next.b);
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

Var Mlp::forward(const Var& x, bool training, Rng& rng) {
  if (layers.empty()) return has_last ? last.forward(x) : x;
  return forward_after_linear(layers[0].lin.forward(x), training, rng, 0);
}

Var Mlp::forward_after_linear(const Var& z0, bool training, Rng& rng, std::size_t k) {
  GATCORE_CHECK(k < layers.size(), "Mlp::forward_after_linear: layer ", k, " but the MLP has ", layers.size(),
                " hidden layers");
  Var z = z0;  // layer k's Linear output
  for (; k < layers.size(); ++k) {
    const Linear* next = k + 1 < layers.size() ? &layers[k + 1].lin : has_last ? &last : nullptr;
    if (!next) return layers[k].after_linear(z, training, rng);
    z = layers[k].fuses_with_next(training) ? layers[k].fused_with_next(z, *next)
                                            : next->forward(layers[k].after_linear(z, training, rng));
  }
  return z;  // the output layer's
}

void Mlp::fold() {
  for (auto& l : layers) l.fold();
}

std::int64_t Mlp::out_width(std::int64_t in) const {
  if (has_last) return last.out;
  return layers.empty() ? in : layers.back().out();
}

}  // namespace gatcore::nn
