#include "gatcore/character/data/dataset_model_description.hpp"

#include <filesystem>
#include <vector>

#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/features/nearest_joints.hpp"

namespace gatcore::character {

ModelDescription describe_dataset_model(const TrainingData& td, const std::string& data_path,
                                        const models::ModelConfig& cfg, const models::Normaliser& norm) {
  const bool any_skeleton = models::any_skeleton(cfg.kind());
  const bool weights = cfg.task == models::Task::weights;
  ModelDescription d;
  // The node features a character command (predict-weights, deform) must compute for this model.
  d.features = any_skeleton ? FeatureKind::bone_candidates : weights ? FeatureKind::neuroskinning : FeatureKind::densegats;
  d.data_path = std::filesystem::absolute(data_path).string();
  d.data_hash = td.hash;
  d.skeleton = td.super.names;
  if (any_skeleton) d.world_columns_ignored = ignores_world_columns(norm);
  if (!any_skeleton && td.nearest_joints == 0) {
    // Which bones every training character had: a character lacking one of
    // them feeds the model an input it never saw (gat deform and
    // predict-weights warn, character_model.hpp).
    std::vector<int> presence(std::size_t(td.super.num_bones()), 0);
    const auto& part = td.part(DatasetPart::train);
    for (std::int32_t c : part)
      for (std::size_t b = 0; b < presence.size(); ++b) presence[b] += td.super.mask[std::size_t(c)][b] != 0;
    d.bone_presence = {presence, int(part.size())};
  }
  if (!weights) {
    d.distortion_scales = td.description.distortion_scales;
    d.nearest_joints = td.nearest_joints;
  }
  // For people reading the checkpoint: the feature layout ("features" is what
  // predict-weights / deform dispatch on); the columns follow "skeleton" (bone names normalised by
  // normalise_bone_name), the statistics are the normaliser's mean / inv_std.
  d.feature_layout = any_skeleton
                         ? "bone-candidates: rest position (3), rest normal (3), then per each vertex's nearest "
                           "bones (out_dim of them, nearest first) 10 bone-relative columns "
                           "(character/features/bone_candidates.hpp); outputs: those bones"
                     : weights
                         ? "neuroskinning: rest position (3), rest normal (3), distance to each skeleton bone "
                           "segment; world frame, hips at the origin, height 1 (character::compute_normalisation)"
                     : td.nearest_joints > 0
                         ? "densegats, nearest joints: posed position (3), posed normal (3), distances to the "
                           "vertex's joint_columns K nearest joints, nearest first (any skeleton; "
                           "character/features/nearest_joints.hpp), then 3 per distortion scale; root frame, "
                           "normalised like neuroskinning"
                         : "densegats: posed position (3), posed normal (3), distance to each skeleton joint, "
                           "then 3 per distortion scale (character/deform/detail_distortion.hpp); root frame, "
                           "normalised like neuroskinning";
  return d;
}

std::string check_checkpoint_dataset(const TrainingData& td, const std::string& data, const ModelDescription& trained,
                                     const std::string& resume, const std::string& from, int asked_nearest) {
  if (!resume.empty() && !trained.data_hash.empty() && trained.data_hash != td.hash)
    return data + " has changed since " + resume + " was trained on it (hash " + td.hash + ", checkpoint " +
           trained.data_hash + ")";
  if (asked_nearest >= 0 && asked_nearest != trained.nearest_joints)
    return resume + " was trained with --joint-columns " + format_joint_columns(trained.nearest_joints) +
           "; a resumed run keeps it";
  if (trained.nearest_joints == 0 && !trained.skeleton.empty() && trained.skeleton != td.super.names)
    return data + "'s super skeleton differs from the one " + from + " was trained on";
  return "";
}

}  // namespace gatcore::character
