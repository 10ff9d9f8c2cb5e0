#pragma once
// Inverted dropout: in training each entry is zeroed with probability p and
// the rest scaled by 1/(1-p); identity in eval. The mask comes from the
// caller's seeded Rng, so a run is reproducible.
#include "gatcore/nn/init.hpp"
#include "gatcore/ops.hpp"

namespace gatcore::nn {

struct Dropout {
  float p = 0.f;
  Var forward(const Var& x, bool training, Rng& rng) const;
};

}  // namespace gatcore::nn
