#include "gatcore/nn/linear.hpp"

namespace gatcore::nn {

Linear::Linear(const Scope& s, std::int64_t in_, std::int64_t out_, Rng& rng, Init init, bool bias)
    : in(in_), out(out_) {
  GATCORE_CHECK(in > 0 && out > 0, "Linear ", s.prefix, ": bad shape [", in, ", ", out, "]");
  W = s.param("W", init_weight(in, out, init, rng));
  if (bias) b = s.param("b", Tensor::zeros(1, out));
}

}  // namespace gatcore::nn
