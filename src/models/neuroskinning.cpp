// NeuroSkinning (Liu et al. 2019) and its w/o-pooling ablation:
//   stage1:     MLP 128, 64 (Linear → BN → LeakyReLU 0.1) → gc.0 (F' 64, K 4, pool 16)
//   global:     MLP 512, 1024 on stage 1 → max pool per character → broadcast
//   local:      gc.1 (64, K 2, pool 24) → gc.2 (64, K 2, pool 64)
//   classifier: concat(local, global) → 1024 → 512 → out → softmax (masked)
// The classifier's first product is computed without the concatenation:
// concat(y, broadcast(g)) W = y W[:local] + broadcast(g W[local:]), the
// second term once per character (the global feature is the same for all
// its vertices): 28 % of the model's multiply-adds, the [n, local + global]
// copy and the [n, global] broadcast (and their gradients) disappear. Same
// parameters, same checkpoints; the sum is reassociated (float rounding only).
// With task = displacement: out = 3, no softmax (DenseGATs' comparison).
// With config.logit_prior (skinweights-any): logits = classifier output +
// Batch::prior, the classifier's last Linear starting at zero, so the
// untrained model is softmax(prior) (bone heat over each vertex's candidate
// bones) and training learns corrections (in log space) to the prior.
// With config.pair_scorer (skinweights-any): the classifier keeps its hidden
// layers, and its last layer (one weight column per candidate slot: what it
// learns about "the 3rd nearest bone" does not carry to the 1st) becomes one
// small MLP applied to every (vertex, slot): context = hidden W_c + b,
// pair = (that slot's pair columns) W_p, leaky(context + pair) → hidden
// layers → 1 score (RigNet's shared scorer; the vertex's context product is
// computed once, not once per slot). Its last Linear is the one that starts
// at zero under logit_prior.
#include "gatcore/backend.hpp"
#include "gatcore/nn/gc_unit.hpp"
#include "gatcore/nn/linear.hpp"
#include "gatcore/nn/mlp.hpp"
#include "models_impl.hpp"

namespace gatcore::models::detail {
namespace {

class NeuroSkinning final : public Model {
 public:
  NeuroSkinning(const ModelConfig& c, std::uint64_t seed) : Model(c) {
    GATCORE_CHECK(!c.gc_heads.empty() && c.gc_heads.size() == c.gc_dims.size() && c.gc_dims.size() == c.gc_pool.size(),
                  "neuroskinning: gc_heads, gc_dims and gc_pool must have the same (non-zero) length");
    nn::Rng init(seed);
    rng_ = nn::Rng(seed ^ 0x9e3779b97f4a7c15ull);
    const nn::Scope root{&reg_, ""};
    nn::DenseLayerOptions dl{Activation::leaky_relu, c.slope, c.batch_norm, 0.f, nn::Init::glorot};
    stage1_ = nn::Mlp(root.sub("stage1"), c.in_dim, c.stage1, 0, dl, init);
    std::int64_t w = stage1_.out_width(c.in_dim);
    for (std::size_t k = 0; k < c.gc_heads.size(); ++k) {
      nn::GcUnitOptions go{int(c.gc_heads[k]), int(c.gc_dims[k]), int(c.gc_pool[k]), c.pool, c.slope};
      gc_.emplace_back(root.sub("gc").sub(std::int64_t(k)), w, go, init);
      w = gc_.back().out();
      if (k == 0) {
        global_ = nn::Mlp(root.sub("global"), w, c.global_mlp, 0, dl, init);
        global_width_ = global_.out_width(w);
      }
    }
    GATCORE_CHECK(c.classifier_dropout >= 0.f && c.classifier_dropout < 1.f,
                  "neuroskinning: classifier_dropout must be in [0, 1), got ", c.classifier_dropout);
    const bool shared = !c.pair_scorer.empty();
    nn::DenseLayerOptions cl = dl;
    cl.dropout = c.classifier_dropout;
    classifier_ = nn::Mlp(root.sub("classifier"), w + global_width_, c.classifier, shared ? 0 : c.out_dim, cl, init);
    nn::Linear* last = &classifier_.last;
    if (shared) {
      GATCORE_CHECK(c.task == Task::weights && !c.classifier.empty() && c.pair_features > 0 &&
                        c.out_dim * c.pair_features <= c.in_dim,
                    "neuroskinning: pair_scorer needs the weights task, a hidden classifier layer and pair_features "
                    "> 0 with out_dim x pair_features (", c.out_dim, " x ", c.pair_features, ") <= in_dim (", c.in_dim,
                    ")");
      const nn::Scope s = root.sub("scorer");
      const std::int64_t h = c.classifier.back(), s0 = c.pair_scorer[0];
      scorer_context_ = nn::Linear(s.sub("context"), h, s0, init, nn::Init::glorot, true);
      scorer_pair_ = nn::Linear(s.sub("pair"), c.pair_features, s0, init, nn::Init::glorot, false);
      for (std::size_t k = 1; k < c.pair_scorer.size(); ++k)
        scorer_hidden_.emplace_back(s.sub("hidden").sub(std::int64_t(k - 1)), c.pair_scorer[k - 1], c.pair_scorer[k],
                                    init, nn::Init::glorot, true);
      scorer_out_ = nn::Linear(s.sub("out"), c.pair_scorer.back(), 1, init, nn::Init::glorot, true);
      last = &scorer_out_;
    }
    if (c.logit_prior) {
      GATCORE_CHECK(c.task == Task::weights, "neuroskinning: logit_prior needs the weights task");
      // The last layer's weight gradient (hidden^T · dL/dlogits) is not zero,
      // so it leaves zero on the first step; the layers below start learning
      // once it has.
      last->W.value().zero_();
      last->b.value().zero_();
    }
  }

  std::vector<int> pool_sizes() const override {
    std::vector<int> p;
    if (cfg_.pool)
      for (auto j : cfg_.gc_pool) p.push_back(int(j));
    return p;
  }

  Var forward(const Batch& b, bool training) override {
    auto nbr = [&](int j) -> GraphPtr {
      if (!cfg_.pool) return nullptr;
      auto it = b.neighbours.find(j);
      GATCORE_CHECK(it != b.neighbours.end(), "neuroskinning: the batch has no neighbour graph for pool size ", j);
      return it->second;
    };
    // The GC units share one buffer: unit k reads columns [0, in_k) and
    // writes [in_k, out_k), which the next unit reads as its input prefix.
    Var buf(backend(b.x.device()).empty(b.x.rows(), gc_.back().out()));
    copy_into(stage1_.forward(Var(b.x), training, rng_), buf.cols_slice(0, gc_[0].in));
    Var y = gc_[0].forward_into(b.graph, nbr(gc_[0].opt.pool_size), buf.cols_slice(0, gc_[0].out()));
    Var glob = segment_max(b.graph, global_.forward(y, training, rng_));  // [characters, global]
    for (std::size_t k = 1; k < gc_.size(); ++k)
      y = gc_[k].forward_into(b.graph, nbr(gc_[k].opt.pool_size), buf.cols_slice(0, gc_[k].out()));
    Var logits = classify(b.graph, y, glob, training);
    if (!cfg_.pair_scorer.empty()) logits = score_pairs(logits, b.x);
    if (cfg_.logit_prior) {
      GATCORE_CHECK(b.prior.defined(), "neuroskinning: the model adds a log prior to its logits (logit_prior) and "
                                       "the batch has none (a skinweights-any sample carries log bone heat)");
      check_shape(b.prior, logits.rows(), logits.cols(), "batch prior");
      logits = add(logits, Var(b.prior));
    }
    return output(logits, b);
  }

  // classifier_(concat(y, broadcast_segments(glob))) without building either.
  Var classify(const GraphPtr& g, const Var& y, const Var& glob, bool training) {
    const bool hidden = !classifier_.layers.empty();
    const nn::Linear& first = hidden ? classifier_.layers[0].lin : classifier_.last;
    const std::int64_t w = y.cols();
    GATCORE_CHECK(first.in == w + glob.cols(), "neuroskinning: classifier input ", first.in, " != ", w, " + ",
                  glob.cols());
    Var per_character = linear(glob, first.W.rows_slice(w, first.in), first.b);
    Var z = linear_segment_bias(g, y, first.W.rows_slice(0, w), per_character);
    if (!hidden) return z;
    return classifier_.forward_after_linear(z, training, rng_, 0);
  }

  // Per slot i: out(leaky(... leaky(context + pair_i W_p) ...)) -> [n, 1];
  // the slots' scores side by side -> [n, out_dim].
  Var score_pairs(const Var& hidden, const Tensor& x) {
    const std::int64_t n = x.rows(), P = cfg_.pair_features, first = cfg_.in_dim - cfg_.out_dim * P;
    Backend& be = backend(x.device());
    const Var context = scorer_context_.forward(hidden);
    std::vector<Var> scores;
    for (std::int64_t i = 0; i < cfg_.out_dim; ++i) {
      Tensor cols = be.empty(n, P);  // the slot's columns, contiguous (an input: no gradient)
      be.copy(x.cols_slice(first + i * P, first + (i + 1) * P), cols);
      Var z = activation(Activation::leaky_relu, add(context, scorer_pair_.forward(Var(cols))), cfg_.slope);
      for (const nn::Linear& l : scorer_hidden_) z = activation(Activation::leaky_relu, l.forward(z), cfg_.slope);
      scores.push_back(scorer_out_.forward(z));
    }
    return concat(scores);
  }

  void fold() override {
    stage1_.fold();
    global_.fold();
    classifier_.fold();
  }

 private:
  nn::Mlp stage1_, global_, classifier_;
  std::vector<nn::GcUnit> gc_;
  nn::Linear scorer_context_, scorer_pair_, scorer_out_;  // config.pair_scorer only
  std::vector<nn::Linear> scorer_hidden_;
  std::int64_t global_width_ = 0;
};

}  // namespace

std::unique_ptr<Model> make_neuroskinning(const ModelConfig& cfg, std::uint64_t seed) {
  return std::make_unique<NeuroSkinning>(cfg, seed);
}

}  // namespace gatcore::models::detail
