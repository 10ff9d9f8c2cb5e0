#pragma once
// Model configuration: one struct for every model, defaults = the papers'
// settings (../shared/SPEC.md). Serialised as "key = value" lines (lists
// comma-separated) so a checkpoint's configuration is human-readable.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/models/model_kind.hpp"

namespace gatcore::models {

enum class Task { displacement, weights };  // offsets [n, 3] / skin weights [n, |B|] (the losses below)
const char* task_name(Task t);
// The displacement loss: MSE (the DenseGATs paper) or L1 (mean absolute
// offset error: seeks the median, so where the network is unsure it keeps
// the LBS result instead of adding the conditional mean; closer to the mean
// per-vertex error the evaluation reports).
enum class DisplacementLoss { mse, l1 };
const char* displacement_loss_name(DisplacementLoss l);
// The skin-weight loss: KL(target || prediction) per vertex (NeuroSkinning),
// or L1, the sum over a vertex's bones of |prediction - target|: the figure
// users judge weights by. KL punishes a faint weight missed on one of the
// artist's bones far more than weight put on the wrong bone, so where a
// network is unsure it spreads weight over every plausible bone; L1 costs
// both alike, so it keeps the likely bones and leaves the rest at 0.
enum class WeightLoss { kl, l1 };
const char* weight_loss_name(WeightLoss l);

struct ModelConfig {
  std::string name = "densegats";  // a ModelKind's name (model_kind_name); kind() reads it
  Task task = Task::displacement;
  DisplacementLoss loss = DisplacementLoss::mse;  // displacement task only
  WeightLoss weight_loss = WeightLoss::kl;         // weights task only (a config without the key: kl)
  std::int64_t in_dim = 0;   // node feature width (required)
  std::int64_t out_dim = 3;  // 3 for displacements, |B| (super skeleton) for weights
  bool batch_norm = true;

  // DenseGATs (and its ablations)
  std::vector<std::int64_t> transform{32, 32};
  int modules = 3, blocks = 6, heads = 8, head_dim = 8;
  float beta = 0.125f;  // self-reinforced stream width / (K·F); 0 = densegats-noself
  bool dense = true;    // false = densegats-nodense
  std::vector<std::int64_t> head{512, 128};
  // Linear skip (DenseGATs family and Ori.GAT, displacement task): output =
  // network(...) + x·S + s, a per-vertex linear map of the (normalised) input
  // columns, and the network's last layer starts at zero, so the untrained network is exactly
  // the skip (models/linear_skip.hpp fits it by least squares before
  // training). Not the paper's architecture; off by default, and configs
  // written before the key existed read as off.
  bool linear_skip = false;
  // Ori.GAT
  int gat_layers = 4;
  // NeuroSkinning
  std::vector<std::int64_t> stage1{128, 64};
  std::vector<std::int64_t> gc_heads{4, 2, 2}, gc_dims{64, 64, 64}, gc_pool{16, 24, 64};
  bool pool = true;  // false = neuroskinning-nopool
  // A log prior on the logits (skinweights-any): logits = classifier output +
  // Batch::prior (the data's log prior per output column, e.g. log(bone heat
  // weight + eps) of each candidate bone), and the classifier's last layer
  // starts at zero, so the untrained model is the prior's softmax and
  // training learns corrections to it. Configs written before the key
  // existed read as off.
  bool logit_prior = false;
  // The bone heat (character/deform/bone_heat.hpp) that prior, and
  // skinweights-any's candidate bones and bone-heat column, follow:
  // prior_weight_limit: with Blender's weight limit (heat under 2.5 % of the
  // vertex dropped, ramped up to 5 %); prior_straight_chains: a joint with a
  // child carrying its chain straight on is one bone ending there (not a fan
  // to every child). Both bring bone heat closer to artists' weights on every
  // family measured (docs/results/bone-heat-vs-blender.md), so new
  // skinweights-any models read them; configs written before a key existed
  // read it as off, so an older model's features are what it was trained on.
  bool prior_weight_limit = false;
  bool prior_straight_chains = false;
  // A shared per-(vertex, output slot) scorer instead of the classifier's
  // last layer (skinweights-any; RigNet's design): the input's last
  // out_dim * pair_features columns are pair_features columns per slot
  // (a vertex's candidate bones), and one MLP of these hidden widths scores
  // every slot from the vertex's context (the classifier's hidden output)
  // and that slot's columns, the same weights for every slot. Empty = the
  // classifier's per-slot output layer (configs before the key: empty).
  std::vector<std::int64_t> pair_scorer;
  int pair_features = 0;
  std::vector<std::int64_t> global_mlp{512, 1024};
  std::vector<std::int64_t> classifier{1024, 512};
  // Dropout after each of the classifier's hidden layers while training
  // (the NeuroSkinning family). A regulariser, not the paper's architecture:
  // with a hundred training characters the classifier learns its training
  // families' conventions. 0 = none (configs before the key: 0).
  float classifier_dropout = 0.f;
  // FC baseline (NeuroSkinning Table 7)
  std::vector<std::int64_t> fc{1024, 512, 512, 256};
  float dropout = 0.6f;
  float slope = 0.1f;  // LeakyReLU slope of the NeuroSkinning-family MLPs
  // PointNet
  std::vector<std::int64_t> point_local{64, 64}, point_global{64, 128, 1024}, point_head{512, 256, 128};
  // Skin-weight post-processing: keep the top κ bones per vertex.
  int top_k = 4;

  // The kind `name` names; throws InvalidArgument for a name that is no kind.
  ModelKind kind() const;
  // The paper defaults of a named model (see model_names()).
  static ModelConfig defaults(const std::string& name, std::int64_t in_dim, std::int64_t out_dim = -1);
  std::string to_text() const;
  // Throws InvalidArgument naming the line for unknown keys / bad values.
  static ModelConfig from_text(const std::string& text);
  bool operator==(const ModelConfig&) const = default;
};

// The name of the loss the model trains with: its task's (cfg.loss or cfg.weight_loss).
const char* loss_name(const ModelConfig& cfg);

}  // namespace gatcore::models
