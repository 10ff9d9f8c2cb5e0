#include "gatcore/character/eval/own_joint_weight_eval.hpp"

#include <chrono>
#include <string>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"

namespace gatcore::character {

std::vector<CharacterWeightEval> evaluate_own_joint_weights(
    const TrainingData& td, DatasetPart part, const OwnJointMethod& method, const WeightEvalOptions& eo,
    const std::function<void(const CharacterWeightEval& r, double seconds, int joints)>& done) {
  const std::int32_t B = td.super.num_bones();
  std::vector<CharacterWeightEval> per;
  for (const std::int32_t c : td.part(part)) {
    const PreparedCharacter& pc = td.characters[std::size_t(c)];
    const auto& j2b = td.super.joint_to_bone[std::size_t(c)];
    const auto t0 = std::chrono::steady_clock::now();
    // The mix's bone heat: the baseline's own settings (top 4, min weight 0.01).
    const SkinWeights w =
        method.model ? mix_with_bone_heat(pc.character,
                                          predict_skin_weights_any(*method.model, *method.norm, pc,
                                                                   method.bone_heat.max_influences),
                                          method.heat_blend)
                     : bone_heat_weights(pc.character, method.bone_heat);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::vector<float> pred = super_weights(w, j2b, B);
    const std::vector<float> truth = super_weights(pc.character.mesh.weights, j2b, B);
    auto r = evaluate_character_weights(pc, pred, truth, B, j2b, td.super.mask[std::size_t(c)], eo, c);
    const std::string& entry = td.description.characters[std::size_t(c)];
    r.name = dataset_character_name(entry);
    if (done) done(r, s, pc.character.skeleton.num_joints());
    per.push_back(std::move(r));
  }
  return per;
}

}  // namespace gatcore::character
