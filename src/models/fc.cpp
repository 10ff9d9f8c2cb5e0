// The fully connected baseline of NeuroSkinning Table 7, per vertex (no graph):
// FC 1024 BN LReLU(0.1) → FC 512 BN LReLU dropout 0.6 → FC 512 BN LReLU →
// FC 256 LReLU → FC out (→ softmax). Layer widths from cfg.fc; dropout after
// the second layer, no BatchNorm on the last hidden layer, as in the table.
#include "gatcore/nn/mlp.hpp"
#include "models_impl.hpp"

namespace gatcore::models::detail {
namespace {

class Fc final : public Model {
 public:
  Fc(const ModelConfig& c, std::uint64_t seed) : Model(c) {
    nn::Rng init(seed);
    rng_ = nn::Rng(seed ^ 0x9e3779b97f4a7c15ull);
    const nn::Scope root{&reg_, ""};
    std::int64_t w = c.in_dim;
    for (std::size_t k = 0; k < c.fc.size(); ++k) {
      nn::DenseLayerOptions o{Activation::leaky_relu, c.slope, c.batch_norm && k + 1 < c.fc.size(),
                              k == 1 ? c.dropout : 0.f, nn::Init::glorot};
      layers_.emplace_back(root.sub("layers").sub(std::int64_t(k)), w, c.fc[k], o, init);
      w = c.fc[k];
    }
    out_ = nn::Linear(root.sub("layers").sub(std::int64_t(c.fc.size())), w, c.out_dim, init);
  }

  Var forward(const Batch& b, bool training) override {
    Var y(b.x);
    for (auto& l : layers_) y = l.forward(y, training, rng_);
    return output(out_.forward(y), b);
  }

  void fold() override {
    for (auto& l : layers_) l.fold();
  }

 private:
  std::vector<nn::DenseLayer> layers_;
  nn::Linear out_;
};

}  // namespace

std::unique_ptr<Model> make_fc(const ModelConfig& cfg, std::uint64_t seed) { return std::make_unique<Fc>(cfg, seed); }

}  // namespace gatcore::models::detail
