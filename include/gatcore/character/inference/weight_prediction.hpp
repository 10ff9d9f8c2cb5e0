#pragma once
// NeuroSkinning for a new character: skin weights predicted by a trained
// skin-weight model (neuroskinning, neuroskinning-nopool, pointnet, fc) from
// the character's rest mesh and skeleton, expressed on its own joints.
#include <string>
#include <vector>

#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/rig/character.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::character {

struct WeightPrediction {
  SkinWeights weights;  // per welded vertex, the character's joint ids, <= max_influences each, summing to 1
  BoneMapping mapping;
  double seconds_features = 0, seconds_inference = 0;
};

// The same features as training (training_data.hpp: NeuroSkinning features of
// the world-frame, normalised rest mesh in the model's bone order, geodesic
// neighbours for the pooling sizes the model needs), the model's bone mask =
// the bones the character has, then the top `max_influences` bones per vertex
// renormalised, mapped back to joints. The model runs on its device.
WeightPrediction predict_skin_weights(models::Model& model, const models::Normaliser& norm,
                                      const std::vector<std::string>& bones, const Character& ch,
                                      int max_influences = 4, const BoneAliases& aliases = {});

// The skeleton-agnostic model (skinweights-any, trained on
// features/bone_candidates.hpp's features with K = model out_dim candidates):
// no bone names, no mapping, any skeleton. `mapping` stays empty.
WeightPrediction predict_skin_weights_any(models::Model& model, const models::Normaliser& norm, const Character& ch,
                                          int max_influences = 4);
// The same on a prepared (world-frame) character (evaluation).
SkinWeights predict_skin_weights_any(models::Model& model, const models::Normaliser& norm,
                                     const PreparedCharacter& pc, int max_influences = 4);

}  // namespace gatcore::character
