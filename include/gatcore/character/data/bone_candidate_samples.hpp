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
// name a joint), log prior (bone_heat_log_prior), the mesh graph. `candidates` (optional) receives the lists.
models::Sample bone_candidate_sample(const PreparedCharacter& pc, int k, BoneCandidates* candidates = nullptr);

std::vector<models::Sample> bone_candidate_samples(const TrainingData& data, DatasetPart part, int k);

}  // namespace gatcore::character
