#pragma once
// Training samples of the skeleton-agnostic skin-weight model (skinweights-any,
// features/bone_candidates.hpp): one per character, its own K nearest bones per
// vertex as the output columns, so characters with any skeleton share a batch.
#include <vector>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::character {

// The sample of one prepared character: candidate features, candidate
// targets (the artist's weights), bone mask [1, k] (1 for the candidates that
// name a joint), log prior (bone_heat_log_prior), the mesh graph, over the
// model's bone heat `heat` (prior_bone_heat of its config). `candidates`
// (optional) receives the lists.
models::Sample bone_candidate_sample(const PreparedCharacter& pc, int k, const BoneHeatParams& heat,
                                     BoneCandidates* candidates = nullptr);

std::vector<models::Sample> bone_candidate_samples(const TrainingData& data, DatasetPart part, int k,
                                                   const BoneHeatParams& heat);

// The vertex columns of the bone-candidate features (rest position and
// normal) are the only ones measured in the world frame rather than from the
// character's own bones. A model that reads them can learn where a body part
// sits in a humanoid's frame (the head at the top, the hands at the sides),
// which means nothing on a quadruped, a spider or a mech. This makes `norm`
// ignore them: their inv_std becomes 0, so each normalises to 0 whatever the
// character (Normaliser's rule for a constant column), in training and, since
// the checkpoint stores the normaliser, in every prediction. (gat train
// --world-columns ignore; docs/RESULTS.md.)
void ignore_world_columns(models::Normaliser& norm);
// Whether `norm` (of bone-candidate features) ignores them.
bool ignores_world_columns(const models::Normaliser& norm);

}  // namespace gatcore::character
