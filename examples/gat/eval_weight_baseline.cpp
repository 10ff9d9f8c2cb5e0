#include "eval_weight_baseline.hpp"
#include "cli_options.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "progress.hpp"

using namespace gatcore;

namespace gat {

int eval_weight_baseline(const std::string& method, const std::string& data, const std::string& part, long poses,
                         long seed, double min_weight, const std::string& json_path, bool quiet, int confusions,
                         models::LoadedModel* model, float heat_blend) {
  if (!model && method != "bone-heat") {
    std::fprintf(stderr, "gat eval: --baseline expects bone-heat, got '%s'\n", method.c_str());
    return 2;
  }
  if (data.empty()) {
    std::fprintf(stderr, "gat eval: --baseline needs a dataset (--data)\n");
    return 2;
  }
  if (part != "test" && part != "validation" && part != "train") {
    std::fprintf(stderr, "gat eval: --part expects test, validation or train, got '%s'\n", part.c_str());
    return 2;
  }
  const character::TrainingData td = [&] {
    Progress loading("preparing the characters of " + data, 0, "characters", quiet);
    return character::load_training_data(data, loading.callback());
  }();
  const auto p = part == "test" ? character::DatasetPart::test
                 : part == "validation" ? character::DatasetPart::validation : character::DatasetPart::train;
  const auto& chars = td.part(p);
  if (chars.empty()) {
    std::fprintf(stderr, "gat eval: %s has no %s characters\n", data.c_str(), part.c_str());
    return 2;
  }
  character::BoneHeatParams bp;
  bp.min_weight = model ? 0.0f : min_weight >= 0 ? float(min_weight) : 0.01f;
  character::WeightEvalOptions eo;
  eo.poses = int(poses);
  eo.pose_angle = td.description.pose_angle;
  eo.seed = std::uint32_t(seed);
  if (model) {
    eo.min_weight = min_weight > 0 ? float(min_weight) : 0.0f;
    model->model->fold_batch_norm();
  }
  const std::int32_t B = td.super.num_bones();
  const std::string label =
      model && heat_blend > 0 ? method + "+heat" + number_text(double(heat_blend)) : method;
  if (model)
    std::printf("gat eval: %s (top %d, min weight %.3g%s) on the %zu %s characters of %s\n", label.c_str(),
                bp.max_influences, double(eo.min_weight),
                heat_blend > 0 ? (", mixed with bone heat at " + number_text(double(heat_blend))).c_str() : "",
                chars.size(), part.c_str(), data.c_str());
  else
    std::printf("gat eval: bone heat (top %d, min weight %.3g) on the %zu %s characters of %s\n", bp.max_influences,
                double(bp.min_weight), chars.size(), part.c_str(), data.c_str());
  std::vector<character::CharacterWeightEval> per;
  Progress progress("evaluating " + part + " characters", std::int64_t(chars.size()), "characters", quiet);
  for (const std::int32_t c : chars) {
    progress.update(std::int64_t(per.size()));
    const character::PreparedCharacter& pc = td.characters[std::size_t(c)];
    const auto& j2b = td.super.joint_to_bone[std::size_t(c)];
    const auto t0 = std::chrono::steady_clock::now();
    // The mix's bone heat: the baseline's own settings (top 4, min weight 0.01).
    const character::SkinWeights w =
        model ? character::mix_with_bone_heat(
                    pc.character, character::predict_skin_weights_any(*model->model, model->norm, pc, bp.max_influences),
                    heat_blend)
              : character::bone_heat_weights(pc.character, bp);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::vector<float> pred = character::super_weights(w, j2b, B);
    const std::vector<float> truth = character::super_weights(pc.character.mesh.weights, j2b, B);
    auto r = character::evaluate_character_weights(pc, pred, truth, B, j2b, td.super.mask[std::size_t(c)], eo, c);
    const std::string& entry = td.description.characters[std::size_t(c)];
    r.name = character::dataset_character_name(entry);
    progress.finish();  // the character's line replaces it
    if (!quiet)
      std::printf("  %s: %lld vertices, %d joints, %.2f s\n", r.name.c_str(), static_cast<long long>(r.vertices),
                pc.character.skeleton.num_joints(), s);
    per.push_back(std::move(r));
  }
  print_weight_table(per, eo, model ? label : std::string("bone-heat"), json_path, confusions);
  return 0;
}

void print_weight_table(const std::vector<character::CharacterWeightEval>& per, const character::WeightEvalOptions& eo,
                        const std::string& method, const std::string& json_path, int confusions) {
  std::printf("\n%s", character::weight_eval_markdown(per).c_str());
  std::printf("(deformation: LBS with predicted vs artist weights, %d random poses within +-%.2f rad, two worst "
              "poses, divided by the character's height)\n",
              eo.poses, double(eo.pose_angle));
  std::printf("%s", character::weight_eval_confusions_markdown(per, confusions).c_str());
  if (!json_path.empty()) {
    character::write_text_atomic(json_path, character::weight_eval_json(method, per, eo, confusions));
    std::printf("  JSON: %s\n", json_path.c_str());
  }
}

}  // namespace gat
