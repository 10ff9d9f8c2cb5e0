#pragma once
// NeuroSkinning's per-character skin-weight metrics for a method that works
// on each character's own joints: bone heat (the classical baseline) or the
// skeleton-agnostic model (skinweights-any, optionally mixed with bone heat),
// so baselines and models share one protocol (gat eval --baseline, and
// gat eval on a skinweights-any checkpoint).
#include <cstddef>
#include <functional>
#include <vector>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/models/model.hpp"

namespace gatcore::character {

struct OwnJointMethod {
  // null: bone heat with `bone_heat`; else a skinweights-any model (its batch
  // norm folded) whose top bone_heat.max_influences weights are mixed with
  // bone heat's at `heat_blend` (0: the model alone).
  models::Model* model = nullptr;
  const models::Normaliser* norm = nullptr;
  float heat_blend = 0.0f;
  BoneHeatParams bone_heat;
};

// Each character of `part`, in order; `done` (when set) after each with its
// metrics, the seconds the method took and the character's joint count.
// r.name: the dataset entry ("procedural:..."), or "folder/stem" of a file.
std::vector<CharacterWeightEval> evaluate_own_joint_weights(
    const TrainingData& td, DatasetPart part, const OwnJointMethod& method, const WeightEvalOptions& eo,
    const std::function<void(const CharacterWeightEval& r, double seconds, int joints)>& done = {});

}  // namespace gatcore::character
