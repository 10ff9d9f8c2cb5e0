#include "gatcore/character/data/bone_candidate_samples.hpp"

#include "gatcore/error.hpp"

namespace gatcore::character {

models::Sample bone_candidate_sample(const PreparedCharacter& pc, int k, const BoneHeatParams& heat,
                                     BoneCandidates* candidates) {
  BoneCandidates c = bone_candidate_features(pc, k, heat);
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

std::vector<models::Sample> bone_candidate_samples(const TrainingData& data, DatasetPart part, int k,
                                                   const BoneHeatParams& heat) {
  std::vector<models::Sample> out;
  for (std::int32_t c : data.part(part)) {
    models::Sample m = bone_candidate_sample(data.characters[std::size_t(c)], k, heat);
    m.name = data.description.characters[std::size_t(c)];
    out.push_back(std::move(m));
  }
  return out;
}

void ignore_world_columns(models::Normaliser& norm) {
  GATCORE_CHECK(norm.defined() && norm.inv_std.rows() == 1 && norm.inv_std.cols() >= kVertexColumns,
                "ignore_world_columns: the normaliser has no ", kVertexColumns, " vertex columns");
  for (int c = 0; c < kVertexColumns; ++c) norm.inv_std.at(0, c) = 0.0f;
}

bool ignores_world_columns(const models::Normaliser& norm) {
  if (!norm.defined() || norm.inv_std.rows() != 1 || norm.inv_std.cols() < kVertexColumns) return false;
  for (int c = 0; c < kVertexColumns; ++c)
    if (norm.inv_std.at(0, c) != 0.0f) return false;
  return true;
}

}  // namespace gatcore::character
