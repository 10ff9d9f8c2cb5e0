#include "gatcore/character/inference/weight_prediction.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/predict.hpp"

namespace gatcore::character {

WeightPrediction predict_skin_weights(models::Model& model, const models::Normaliser& norm,
                                      const std::vector<std::string>& bones, const Character& ch, int max_influences,
                                      const BoneAliases& aliases) {
  GATCORE_CHECK(model.config().task == models::Task::weights, ch.name, ": ", model.config().name,
                " predicts displacements, not skin weights");
  GATCORE_CHECK(max_influences >= 1, "predict_skin_weights: max_influences must be >= 1, got ", max_influences);
  const auto t0 = std::chrono::steady_clock::now();
  WeightPrediction out;
  out.mapping = map_bones(ch.skeleton, bones, aliases, ch.name);
  const auto B = static_cast<std::int64_t>(bones.size());
  const PreparedCharacter pc = prepare_character(ch, DeltaMushParams{0, 0.5f});  // no smoothing needed here
  const std::vector<std::int32_t> vertices = all_vertices(pc.character.mesh.num_vertices());
  models::Sample s;
  s.name = ch.name;
  s.features = features_in_bone_order(neuroskinning_rest_features(pc, vertices), out.mapping);
  s.graph = share(induced_subgraph(pc.mesh_graph, vertices));
  int k = 1;
  for (int p : model.pool_sizes()) k = std::max(k, p);
  if (!model.pool_sizes().empty())
    s.geodesic_neighbours = geodesic_knn_lists(pc.character.mesh.positions, pc.character.mesh.triangles, k);
  s.bone_mask = Tensor::zeros(1, B);
  for (std::int64_t b = 0; b < B; ++b) s.bone_mask.at(0, b) = out.mapping.bone_to_joint[b] >= 0 ? 1.f : 0.f;
  const auto t1 = std::chrono::steady_clock::now();
  const Tensor y = models::predict(model, s, norm, max_influences);
  const auto t2 = std::chrono::steady_clock::now();

  const std::int64_t n = y.rows();
  SkinWeights& w = out.weights;
  w.ptr.assign(1, 0);
  for (std::int64_t v = 0; v < n; ++v) {
    std::vector<std::pair<std::int32_t, float>> row;
    for (std::int64_t b = 0; b < B; ++b) {
      const float p = y.at(v, b);
      GATCORE_CHECK(std::isfinite(p), ch.name, ": the model predicted a non-finite weight at vertex ", v);
      // Masked bones have probability exactly 0, so every kept bone has a joint.
      if (p > 0.f && out.mapping.bone_to_joint[b] >= 0) row.push_back({out.mapping.bone_to_joint[b], p});
    }
    std::sort(row.begin(), row.end());
    float sum = 0.f;
    for (const auto& e : row) sum += e.second;
    GATCORE_CHECK(sum > 0.f, ch.name, ": vertex ", v, " got no weight on any of its joints");
    for (const auto& e : row) {
      w.joint.push_back(e.first);
      w.weight.push_back(e.second / sum);
    }
    w.ptr.push_back(static_cast<std::int64_t>(w.joint.size()));
  }
  out.seconds_features = std::chrono::duration<double>(t1 - t0).count();
  out.seconds_inference = std::chrono::duration<double>(t2 - t1).count();
  return out;
}

SkinWeights predict_skin_weights_any(models::Model& model, const models::Normaliser& norm,
                                     const PreparedCharacter& pc, int max_influences) {
  const models::ModelConfig& cfg = model.config();
  GATCORE_CHECK(cfg.task == models::Task::weights && models::any_skeleton(cfg.kind()), pc.character.name, ": ", cfg.name,
                " is not the skeleton-agnostic skin-weight model (skinweights-any)");
  GATCORE_CHECK(max_influences >= 1, "predict_skin_weights_any: max_influences must be >= 1, got ", max_influences);
  const int k = static_cast<int>(cfg.out_dim);
  BoneCandidates c = bone_candidate_features(pc, k, prior_bone_heat(cfg));
  GATCORE_CHECK(cfg.in_dim == c.features.cols(), pc.character.name, ": the model takes ", cfg.in_dim,
                " features, the bone candidates give ", c.features.cols());
  models::Sample s;
  s.name = pc.character.name;
  s.features = c.features;
  if (cfg.logit_prior) s.prior = bone_heat_log_prior(c);
  s.graph = share(CsrGraph(pc.mesh_graph));
  s.bone_mask = Tensor::zeros(1, k);
  for (int i = 0; i < c.valid; ++i) s.bone_mask.at(0, i) = 1.0f;
  const Tensor y = models::predict(model, s, norm, max_influences);
  return weights_from_candidates(c, y.contiguous() ? y : y.clone());
}

WeightPrediction predict_skin_weights_any(models::Model& model, const models::Normaliser& norm, const Character& ch,
                                          int max_influences) {
  const auto t0 = std::chrono::steady_clock::now();
  const PreparedCharacter pc = prepare_character(ch, DeltaMushParams{0, 0.5f});
  WeightPrediction out;
  const auto t1 = std::chrono::steady_clock::now();
  out.weights = predict_skin_weights_any(model, norm, pc, max_influences);
  const auto t2 = std::chrono::steady_clock::now();
  out.seconds_features = std::chrono::duration<double>(t1 - t0).count();
  out.seconds_inference = std::chrono::duration<double>(t2 - t1).count();
  return out;
}

}  // namespace gatcore::character
