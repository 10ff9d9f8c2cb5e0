// DenseGATs (and the w/o-self / w/o-dense ablations):
//   transform: Linear 32 → BN → tanh → Linear 32 → BN → tanh  (written into module 0's buffer)
//   modules.m: dense module of `blocks` GAT blocks (one buffer per module)
//   transitions.m: GAT block between modules m and m+1 (writes into module m+1's buffer)
//   head: Linear 512 → BN → tanh → Linear 128 → BN → tanh → Linear out
//   skip (config.linear_skip): Linear in → out on the input columns, added
//     to the head's output; the head's last Linear then starts at zero
#include "gatcore/nn/dense_module.hpp"
#include "gatcore/nn/mlp.hpp"
#include "models_impl.hpp"

namespace gatcore::models::detail {
namespace {

class DenseGats final : public Model {
 public:
  DenseGats(const ModelConfig& c, std::uint64_t seed) : Model(c) {
    GATCORE_CHECK(c.modules >= 1 && c.blocks >= 1 && !c.transform.empty(), "densegats: needs >= 1 module, ",
                  ">= 1 block and a transform layer");
    nn::Rng init(seed);
    rng_ = nn::Rng(seed ^ 0x9e3779b97f4a7c15ull);
    const nn::Scope root{&reg_, ""};
    nn::DenseLayerOptions dl{Activation::tanh, 0.f, c.batch_norm, 0.f, nn::Init::glorot};
    std::int64_t w = c.in_dim;
    for (std::size_t k = 0; k < c.transform.size(); ++k) {
      transform_.emplace_back(root.sub("transform").sub(std::int64_t(k)), w, c.transform[k], dl, init);
      w = c.transform[k];
    }
    nn::GatBlockOptions go{c.heads, c.head_dim, c.beta, 0.2f, c.batch_norm};
    for (int m = 0; m < c.modules; ++m) {
      modules_.emplace_back(root.sub("modules").sub(m), w, c.blocks, go, c.dense, init);
      w = modules_.back().out();
      if (m + 1 < c.modules) {
        transitions_.emplace_back(root.sub("transitions").sub(m), w, go, init);
        w = transitions_.back().out();
      }
    }
    head_ = nn::Mlp(root.sub("head"), w, c.head, c.out_dim, dl, init);
    if (c.linear_skip) {
      GATCORE_CHECK(c.task == Task::displacement, "densegats: linear_skip needs the displacement task");
      skip_ = nn::Linear(root.sub("skip"), c.in_dim, c.out_dim, init, nn::Init::zeros, true);
      // A residual head: the untrained network is the skip alone (zero, or
      // the least-squares fit), and the graph part learns what the linear map
      // cannot. The last layer's gradient (hidden^T · dL/dy) is not zero, so
      // it leaves zero on the first step.
      head_.last.W.value().zero_();
    }
  }

  Var forward(const Batch& b, bool training) override {
    const std::int64_t n = b.x.rows();
    Var buf = modules_[0].make_buffer(n, b.x.device());
    Var y(b.x);
    for (std::size_t k = 0; k < transform_.size(); ++k)
      y = transform_[k].forward(y, training, rng_,
                                k + 1 == transform_.size() ? nn::DenseModule::input_slot(buf, modules_[0].in) : Var{});
    for (std::size_t m = 0; m < modules_.size(); ++m) {
      y = modules_[m].forward(b.graph, buf, training);
      if (m + 1 < modules_.size()) {
        buf = modules_[m + 1].make_buffer(n, b.x.device());
        transitions_[m].forward(b.graph, y, training, nn::DenseModule::input_slot(buf, modules_[m + 1].in));
      }
    }
    Var out = head_.forward(y, training, rng_);
    if (cfg_.linear_skip) out = add(out, skip_.forward(Var(b.x)));
    return output(out, b);
  }

  void fold() override {
    for (auto& l : transform_) l.fold();
    head_.fold();
  }

 private:
  std::vector<nn::DenseLayer> transform_;
  std::vector<nn::DenseModule> modules_;
  std::vector<nn::GatBlock> transitions_;
  nn::Mlp head_;
  nn::Linear skip_;  // config.linear_skip
};

}  // namespace

std::unique_ptr<Model> make_densegats(const ModelConfig& cfg, std::uint64_t seed) {
  return std::make_unique<DenseGats>(cfg, seed);
}

}  // namespace gatcore::models::detail
