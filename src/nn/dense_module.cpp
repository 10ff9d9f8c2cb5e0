#include "gatcore/nn/dense_module.hpp"
#include "gatcore/backend.hpp"

namespace gatcore::nn {

DenseModule::DenseModule(const Scope& s, std::int64_t in_, int num_blocks, const GatBlockOptions& opt, bool dense_,
                         Rng& rng)
    : in(in_), dense(dense_) {
  std::int64_t w = in;
  for (int m = 0; m < num_blocks; ++m) {
    blocks.emplace_back(s.sub("blocks").sub(m), dense ? w : (m == 0 ? in : block_width), opt, rng);
    block_width = blocks.back().out();
    w += block_width;
  }
}

Var DenseModule::make_buffer(std::int64_t n, Device d) const { return Var(backend(d).empty(n, buffer_width())); }

Var DenseModule::forward(const GraphPtr& g, const Var& buf, bool training) {
  GATCORE_CHECK(buf.cols() == buffer_width(), "DenseModule: buffer has ", buf.cols(), " columns, expected ",
                buffer_width());
  std::int64_t c0 = in, prev = 0;
  for (auto& b : blocks) {
    Var input = dense ? buf.cols_slice(0, c0) : buf.cols_slice(prev, c0);
    b.forward(g, input, training, buf.cols_slice(c0, c0 + block_width));
    prev = c0;
    c0 += block_width;
  }
  if (dense) return buf;
  return buf.cols_slice(prev, c0);
}

}  // namespace gatcore::nn
