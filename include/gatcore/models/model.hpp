#pragma once
// Models selectable by name: densegats, densegats-noself, densegats-nodense,
// origat, neuroskinning, neuroskinning-nopool, skinweights-any, fc, pointnet.
//
// A Model owns its parameters in an nn::Registry (hierarchical names) and
// maps a Batch (block-diagonal graph + features) to per-vertex outputs:
// displacements [n, 3] (Task::displacement) or skin-weight probabilities
// [n, |B|] (Task::weights; bones masked out get exactly zero).
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gatcore/models/config.hpp"
#include "gatcore/nn/registry.hpp"
#include "gatcore/nn/init.hpp"
#include "gatcore/ops.hpp"

namespace gatcore::models {

struct Batch {
  GraphPtr graph;  // block-diagonal, self-loops; segment_ptr = one segment per character
  Tensor x;        // [n, in_dim] (normalised)
  Tensor target;   // [n, out_dim] (may be undefined at inference)
  // pool size J -> graph whose row i lists the J geodesically nearest vertices of i
  std::map<int, GraphPtr> neighbours;
  Tensor mask;  // bone mask, [1, B] or [n, B] (0 = bone absent), or undefined
  Tensor prior; // [n, out_dim] log prior (Sample::prior), or undefined
};

class Model {
 public:
  explicit Model(ModelConfig cfg) : cfg_(std::move(cfg)) {}
  virtual ~Model() = default;
  Model(const Model&) = delete;
  Model& operator=(const Model&) = delete;

  const ModelConfig& config() const { return cfg_; }
  nn::Registry& registry() { return reg_; }
  const nn::Registry& registry() const { return reg_; }
  std::vector<Var> parameters() const { return reg_.parameters(); }
  // Moves parameters and BatchNorm buffers to `d` (before building a Trainer:
  // Adam allocates its moments where the parameters are).
  void to(Device d) { reg_.to(d); }
  // Where the parameters live.
  Device device() const { return reg_.params.empty() ? Device::cpu : reg_.params.front().var.device(); }

  // Probabilities (weights task) or displacements.
  virtual Var forward(const Batch& b, bool training) = 0;
  // Folds every BatchNorm that directly follows a Linear into it (inference
  // only; eval outputs are unchanged). BatchNorms after a nonlinearity (the
  // GAT blocks') stay.
  // A folded model is for inference only: save_checkpoint refuses it.
  void fold_batch_norm() {
    if (!folded_) fold();
    folded_ = true;
  }
  bool folded() const { return folded_; }
  // Neighbour graph sizes forward() needs in Batch::neighbours.
  virtual std::vector<int> pool_sizes() const { return {}; }
  // Dropout randomness (seeded with the model).
  nn::Rng& rng() { return rng_; }

 protected:
  // Softmax of logits with the batch's bone mask (weights task); identity otherwise.
  Var output(const Var& logits, const Batch& b) const;
  virtual void fold() {}
  ModelConfig cfg_;
  nn::Registry reg_;
  bool folded_ = false;
  nn::Rng rng_{0};
};

std::vector<std::string> model_names();
// Builds a model with freshly initialised parameters (seeded).
std::unique_ptr<Model> make_model(const ModelConfig& cfg, std::uint64_t seed);

// Row softmax where mask entries 0 get probability exactly 0. mask is [1, C]
// (uses row_softmax's mask) or [n, C] (per-row, for batches of characters
// with different skeletons); undefined = no mask.
Var masked_softmax(const Var& logits, const Tensor& mask);
// Keeps the k largest weights of each row, zeroes the rest, renormalises.
Tensor top_k_renormalise(const Tensor& weights, int k);
// The task's training loss: displacements MSE or L1 per coordinate
// (cfg.loss), mean over rows and columns; skin weights KL(target ||
// prediction) or the L1 over each vertex's bones (cfg.weight_loss), mean
// over vertices.
Var task_loss(const ModelConfig& cfg, const Var& pred, const Tensor& target);

}  // namespace gatcore::models
