#pragma once
// The model kinds gatcore builds, and what each can do. A kind is read from
// text once (parse_model_kind: a checkpoint's config, a command line) and
// compared as a type everywhere else.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace gatcore::models {

enum class ModelKind {
  densegats,             // DenseGATs (the paper's corrective network)
  densegats_noself,      // its ablation without the self-reinforced stream
  densegats_nodense,     // its ablation without dense connections
  origat,                // Ori.GAT: plain stacked graph attention
  neuroskinning,         // NeuroSkinning (skin weights over the super skeleton's bones)
  neuroskinning_nopool,  // its ablation without geodesic pooling
  skinweights_any,       // NeuroSkinning's network over each vertex's own candidate bones: any skeleton
  fc,                    // NeuroSkinning's fully connected baseline
  pointnet,              // NeuroSkinning's PointNet baseline
};

// Every kind, in the order `gat` lists them.
const std::vector<ModelKind>& all_model_kinds();
// The kind's name as written in configs, checkpoints and on the command line ("skinweights-any").
const char* model_kind_name(ModelKind k);
// nullopt for a name that is no kind.
std::optional<ModelKind> parse_model_kind(std::string_view name);
// Throws InvalidArgument naming the unknown name and the known ones.
ModelKind model_kind_from_name(std::string_view name);

// Predicts per-vertex displacements on top of LBS (the DenseGATs family and Ori.GAT).
bool predicts_displacement(ModelKind k);
// Predicts skin weights (the NeuroSkinning family and its baselines).
bool predicts_skin_weights(ModelKind k);
// DenseGATs or one of its ablations (one network, switches in the config).
bool is_densegats_family(ModelKind k);
// Has a fused inference path (models/deploy.hpp), used by the runtime's deformer.
bool deployable(ModelKind k);
// Works on any skeleton without bone names: its output columns are each vertex's own
// candidate bones, not a fixed skeleton's (skinweights-any).
bool any_skeleton(ModelKind k);
// NeuroSkinning's network (graph units, global feature, classifier): neuroskinning,
// its pooling ablation and skinweights-any.
bool has_neuroskinning_classifier(ModelKind k);
// Reads the NeuroSkinning per-vertex features and trains with NeuroSkinning's
// defaults (batch 12, random vertex samples, step schedule).
bool uses_neuroskinning_features(ModelKind k);

}  // namespace gatcore::models
