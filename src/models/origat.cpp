// Ori.GAT: `gat_layers` plain graph-attention layers (Veličković et al.):
// K heads × F concatenated, LeakyReLU(0.2) logits; hidden layers use
// LeakyReLU(0.01) (stand-in for the original ELU, which gatcore lacks); the
// last layer is one head of width out_dim with no activation.
// Parameters: layers.l.{W, att_dst, att_src, b}; with config.linear_skip also
// skip.{W, b}: a Linear in -> out on the input columns added to the output
// (as in densegats.cpp), the last layer's W starting at zero so the untrained
// model is the skip alone (models/linear_skip.hpp fits it before training).
// That makes a small deploy model (gat distill) start from the least-squares
// part of the correction and spend its few parameters on the rest.
#include <cmath>

#include "gatcore/backend.hpp"

#include "gatcore/nn/linear.hpp"
#include "models_impl.hpp"

namespace gatcore::models::detail {
namespace {

class OriGat final : public Model {
 public:
  OriGat(const ModelConfig& c, std::uint64_t seed) : Model(c) {
    GATCORE_CHECK(c.gat_layers >= 1, "origat: gat_layers must be >= 1");
    nn::Rng init(seed);
    const nn::Scope root{&reg_, ""};
    std::int64_t w = c.in_dim;
    for (int l = 0; l < c.gat_layers; ++l) {
      const bool last = l + 1 == c.gat_layers;
      const int H = last ? 1 : c.heads, F = last ? int(c.out_dim) : c.head_dim;
      const nn::Scope s = root.sub("layers").sub(l);
      Layer L;
      L.heads = H;
      L.W = s.param("W", nn::init_weight(w, std::int64_t(H) * F, nn::Init::glorot, init));
      const float ab = std::sqrt(6.f / float(F + 1));
      L.att_dst = s.param("att_dst", nn::uniform_tensor(H, F, ab, init));
      L.att_src = s.param("att_src", nn::uniform_tensor(H, F, ab, init));
      L.b = s.param("b", Tensor::zeros(1, std::int64_t(H) * F));
      layers_.push_back(L);
      w = std::int64_t(H) * F;
    }
    if (c.linear_skip) {
      GATCORE_CHECK(c.task == Task::displacement, "origat: linear_skip needs the displacement task");
      skip_ = nn::Linear(root.sub("skip"), c.in_dim, c.out_dim, init, nn::Init::zeros, true);
      // dL/dW of the last layer is its input^T (A^T dL/dy), not zero: it leaves zero on the first step.
      layers_.back().W.value().zero_();
    }
  }

  Var forward(const Batch& b, bool) override {
    Var y(b.x);
    for (std::size_t l = 0; l < layers_.size(); ++l) {
      const Layer& L = layers_[l];
      Var z = gat_additive(b.graph, linear(y, L.W, Var{}), L.att_dst, L.att_src, 0.2f);
      y = add_bias(z, L.b);
      if (l + 1 < layers_.size()) y = leaky_relu(y, 0.01f);
    }
    if (cfg_.linear_skip) y = add(y, skip_.forward(Var(b.x)));
    return output(y, b);
  }

 private:
  struct Layer {
    Var W, att_dst, att_src, b;
    int heads = 1;
  };
  // z + b (b broadcast over rows) = linear(z, I, b) would cost a GEMM; use
  // matmul of a ones column instead: ones[n,1] · b[1,C].
  static Var add_bias(const Var& z, const Var& b) {
    Tensor ones = backend(z.device()).empty(z.rows(), 1);
    backend(z.device()).fill(ones, 1.f);
    return add(z, matmul(Var(ones), b));
  }
  std::vector<Layer> layers_;
  nn::Linear skip_;  // config.linear_skip
};

}  // namespace

std::unique_ptr<Model> make_origat(const ModelConfig& cfg, std::uint64_t seed) {
  return std::make_unique<OriGat>(cfg, seed);
}

}  // namespace gatcore::models::detail
