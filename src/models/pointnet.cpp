// PointNet (segmentation variant, without the T-nets): shared per-point MLP
// 64, 64 ("local") → MLP 64, 128, 1024 ("global") → max pool per character →
// broadcast → concat(local, global) → MLP 512, 256, 128 → out (→ softmax).
// Linear → BN → ReLU throughout.
#include "gatcore/nn/mlp.hpp"
#include "gatcore/nn/pooling.hpp"
#include "models_impl.hpp"

namespace gatcore::models::detail {
namespace {

class PointNet final : public Model {
 public:
  PointNet(const ModelConfig& c, std::uint64_t seed) : Model(c) {
    nn::Rng init(seed);
    rng_ = nn::Rng(seed ^ 0x9e3779b97f4a7c15ull);
    const nn::Scope root{&reg_, ""};
    nn::DenseLayerOptions dl{Activation::relu, 0.f, c.batch_norm, 0.f, nn::Init::he};
    local_ = nn::Mlp(root.sub("local"), c.in_dim, c.point_local, 0, dl, init);
    const std::int64_t lw = local_.out_width(c.in_dim);
    global_ = nn::Mlp(root.sub("global"), lw, c.point_global, 0, dl, init);
    head_ = nn::Mlp(root.sub("head"), lw + global_.out_width(lw), c.point_head, c.out_dim, dl, init);
  }

  Var forward(const Batch& b, bool training) override {
    Var l = local_.forward(Var(b.x), training, rng_);
    Var g = nn::global_max_broadcast(b.graph, global_.forward(l, training, rng_));
    return output(head_.forward(concat({l, g}), training, rng_), b);
  }

  void fold() override {
    local_.fold();
    global_.fold();
    head_.fold();
  }

 private:
  nn::Mlp local_, global_, head_;
};

}  // namespace

std::unique_ptr<Model> make_pointnet(const ModelConfig& cfg, std::uint64_t seed) {
  return std::make_unique<PointNet>(cfg, seed);
}

}  // namespace gatcore::models::detail
