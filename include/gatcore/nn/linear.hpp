#pragma once
// y = x·W + b with W [in, out] ("W") and b [1, out] ("b", optional).
#include "gatcore/nn/init.hpp"
#include "gatcore/nn/registry.hpp"
#include "gatcore/ops.hpp"

namespace gatcore::nn {

struct Linear {
  Var W, b;
  std::int64_t in = 0, out = 0;

  Linear() = default;
  Linear(const Scope& s, std::int64_t in, std::int64_t out, Rng& rng, Init init = Init::glorot, bool bias = true);
  Var forward(const Var& x, const Var& into = {}) const { return linear(x, W, b, into); }
};

}  // namespace gatcore::nn
