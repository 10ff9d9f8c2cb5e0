#pragma once
// BatchNorm1d over the rows of [n, C]: batch statistics while training (and
// a running-statistics update), running statistics in eval. Parameters
// "gamma", "beta"; buffers "running_mean", "running_var".
#include "gatcore/nn/linear.hpp"

namespace gatcore::nn {

struct BatchNorm1d {
  Var gamma, beta;
  BatchNormState state;

  BatchNorm1d() = default;
  BatchNorm1d(const Scope& s, std::int64_t channels, float momentum = 0.1f, float eps = 1e-5f);
  Var forward(const Var& x, bool training, const Var& into = {}) { return batch_norm(x, gamma, beta, state, training, into); }
};

// Folds an eval-mode BatchNorm that directly follows `lin` into its weights:
// W' = W·diag(s), b' = (b − μ)·s + β with s = γ / sqrt(σ² + ε). `lin` gains a
// bias if it had none. The values are overwritten in place (same Vars).
void fold_batch_norm(Linear& lin, const BatchNorm1d& bn);

}  // namespace gatcore::nn
