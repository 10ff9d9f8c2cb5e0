#pragma once
// What a character model was trained on, as its checkpoint records it: the
// node features, the bones its columns follow, its joint columns and
// distortion scales, which bones every training character had, and the data.
// Written by training (gat train, gat distill) and read by every command and
// the runtime that applies the model to a character; this file and its
// source are the one place that knows the metadata keys ("features",
// "skeleton", "joint_columns", "distortion_scales", "bone_presence",
// "training_characters", "world_columns", "feature_layout", "data",
// "data_path", "data_hash", "min_weight", "heat_blend"). The checkpoint itself (models/checkpoint.hpp)
// stays a safetensors file with a string metadata map.
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "gatcore/models/checkpoint.hpp"

namespace gatcore::character {

// The node features a checkpoint was trained on (metadata "features";
// checkpoints written before that key: a dataset's features if it records a
// data_path, else the embedded tube's).
enum class FeatureKind { tube, neuroskinning, densegats, bone_candidates };
FeatureKind checkpoint_features(const models::CheckpointFile& f);
// "tube", "neuroskinning", "densegats", "bone-candidates": the metadata value.
const char* feature_kind_name(FeatureKind k);
// The DenseGATs detail-distortion scales a checkpoint was trained with
// (metadata "distortion_scales"; absent: none, the paper's features).
std::vector<int> checkpoint_distortion_scales(const models::CheckpointFile& f, const std::string& path);

// The joint columns of a displacement checkpoint (metadata "joint_columns":
// "bones", the paper's, or "nearest:K", any skeleton; absent: "bones"):
// 0 or K (features/nearest_joints.hpp).
int checkpoint_nearest_joints(const models::CheckpointFile& f, const std::string& path);

// How many of a model's training characters had each of its bones
// (checkpoint metadata "bone_presence": counts in "skeleton" order, and
// "training_characters"). Recorded for bone-column models.
struct BonePresence {
  std::vector<int> count;  // [bones]; empty: not recorded (older checkpoints)
  int characters = 0;
};
// Reads it; empty when the keys are absent. Throws InvalidArgument naming
// `path` when they are malformed or their length is not num_bones.
BonePresence checkpoint_bone_presence(const models::CheckpointFile& f, const std::string& path,
                                      std::size_t num_bones);
// The metadata value: the counts joined by commas.
std::string format_bone_presence(const std::vector<int>& count);

// Bone names joined by commas, as "skeleton" records them.
std::string joined_bone_names(const std::vector<std::string>& names);

// How a skin-weight model's top-k weights are post-processed before use:
// mixed with bone heat's at `heat_blend` ((1 - s) * model + s * bone heat,
// top k kept), then influences below `min_weight` of the vertex's total
// dropped and the rest renormalised. A softmax leaves small weights on every
// candidate where artists use about two influences per vertex; the values are
// chosen on held-out characters of the training families
// (eval/weight_calibration.hpp), never on the test characters.
struct WeightPostprocess {
  float min_weight = 0.0f;
  float heat_blend = 0.0f;
};

// All of the above in one struct.
struct ModelDescription {
  FeatureKind features = FeatureKind::tube;
  // The bones the model's columns (and, for skin weights, outputs) follow, by
  // normalised name ("skeleton"); the super skeleton of the training dataset.
  std::vector<std::string> skeleton;
  // Displacement models (features densegats): 0 (the skeleton's bones) or K
  // nearest joints ("joint_columns"), and the detail-distortion scales.
  int nearest_joints = 0;
  std::vector<int> distortion_scales;
  BonePresence bone_presence;
  // Any-skeleton models: whether the vertex's world-frame position and normal
  // columns are ignored ("world_columns": ignore / use), for people reading the
  // file; the normaliser is what predictions follow.
  std::optional<bool> world_columns_ignored;
  // The feature layout in words ("feature_layout"), for people reading the file.
  std::string feature_layout;
  // The training dataset ("data_path", absolute, and its hash); empty: the
  // embedded tube character.
  std::string data_path, data_hash;
  // What it was trained on in words ("data", for people reading the file:
  // "dataset" or "embedded tube character", written from data_path); empty
  // when the file has no such entry.
  std::string data;
  // Skin-weight models: the post-processing calibrated for it ("min_weight",
  // "heat_blend"); absent: none (the model's top-k weights as they are).
  std::optional<WeightPostprocess> postprocess;
};

// The metadata entries of `d` (the keys above; the conditional ones only where they apply).
std::map<std::string, std::string> model_description_metadata(const ModelDescription& d);
// Reads every key (absent ones as older checkpoints mean them). Throws
// InvalidArgument naming `path` and the key for a malformed value.
ModelDescription read_model_description(const models::CheckpointFile& f, const std::string& path);

}  // namespace gatcore::character
