#include "gatcore/character/data/bone_candidate_samples.hpp"

namespace gatcore::character {

models::Sample bone_candidate_sample(const PreparedCharacter& pc, int k, BoneCandidates* candidates) {
  BoneCandidates c = bone_candidate_features(pc, k);
  models::Sample m;
  m.name = pc.character.name;
  m.features = c.features;
  m.target = candidate_targets(c, pc.character.mesh.weights);
  m.target_mass = candidate_target_mass(c, pc.character.mesh.weights);
  m.target_dominant = candidate_target_dominant(c, pc.character.mesh.weights);
  m.prior = bone_heat_log_prior(c);
  m.bone_mask = Tensor::zeros(1, k);
  for (int i = 0; i < c.valid; ++i) m.bone_mask.at(0, i) = 1.0f;
  m.graph = share(CsrGraph(pc.mesh_graph));
  if (candidates) *candidates = std::move(c);
  return m;
}

std::vector<models::Sample> bone_candidate_samples(const TrainingData& data, DatasetPart part, int k) {
  std::vector<models::Sample> out;
  for (std::int32_t c : data.part(part)) {
    models::Sample m = bone_candidate_sample(data.characters[std::size_t(c)], k);
    m.name = data.description.characters[std::size_t(c)];
    out.push_back(std::move(m));
  }
  return out;
}

}  // namespace gatcore::character
