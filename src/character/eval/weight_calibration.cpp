#include "gatcore/character/eval/weight_calibration.hpp"

#include <algorithm>
#include <cmath>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/rig/blend_weights.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model_kind.hpp"

namespace gatcore::character {

namespace {

void check_grid_values(const CalibrationGrid& grid, int max_influences, const char* what) {
  for (const float m : grid.min_weights)
    GATCORE_CHECK(std::isfinite(m) && m >= 0.0f && m < 1.0f, what, ": a min weight must be in [0, 1), got ", m);
  for (const float h : grid.heat_blends)
    GATCORE_CHECK(std::isfinite(h) && h >= 0.0f && h <= 1.0f, what, ": a heat blend must be in [0, 1], got ", h);
  GATCORE_CHECK(max_influences >= 1, what, ": max_influences must be >= 1, got ", max_influences);
}

}  // namespace

std::vector<CalibrationPoint> score_postprocess_grid(const TrainingData& td, std::int32_t character,
                                                     const SkinWeights& own, const SkinWeights& heat,
                                                     const CalibrationGrid& grid, int max_influences) {
  GATCORE_CHECK(character >= 0 && std::size_t(character) < td.characters.size(), "score_postprocess_grid: character ",
                character, " of ", td.characters.size());
  check_grid_values(grid, max_influences, "score_postprocess_grid");
  const PreparedCharacter& pc = td.characters[std::size_t(character)];
  const std::int64_t n = pc.character.mesh.num_vertices();
  GATCORE_CHECK(own.num_vertices() == n && heat.num_vertices() == n, "score_postprocess_grid: ",
                pc.character.name, " has ", n, " vertices; the weights have ", own.num_vertices(),
                " and bone heat's ", heat.num_vertices());
  const auto& j2b = td.super.joint_to_bone[std::size_t(character)];
  const auto& mask = td.super.mask[std::size_t(character)];
  const std::int32_t B = td.super.num_bones();
  const std::vector<float> truth = super_weights(pc.character.mesh.weights, j2b, B);
  WeightEvalOptions eo;
  eo.poses = 0;  // the L1 and dominant bone only
  std::vector<CalibrationPoint> out;
  for (const float share : grid.heat_blends) {
    const SkinWeights mixed = share > 0.0f ? blend_weights(own, heat, share, max_influences) : own;
    const std::vector<float> pred = super_weights(mixed, j2b, B);
    for (const float min_weight : grid.min_weights) {
      eo.min_weight = min_weight;
      const CharacterWeightEval r = evaluate_character_weights(pc, pred, truth, B, j2b, mask, eo, character);
      out.push_back({{min_weight, share}, r.weights.l1_mean, r.dominant});
    }
  }
  return out;
}

WeightCalibration calibrate_weight_postprocess(const TrainingData& td, DatasetPart part, models::Model& model,
                                               const models::Normaliser& norm, const CalibrationGrid& grid,
                                               int max_influences) {
  const auto has_zero = [](const std::vector<float>& v) { return std::find(v.begin(), v.end(), 0.0f) != v.end(); };
  GATCORE_CHECK(has_zero(grid.min_weights) && has_zero(grid.heat_blends),
                "calibrate_weight_postprocess: the grid must include min weight 0 and heat blend 0 (the model's own "
                "weights)");
  check_grid_values(grid, max_influences, "calibrate_weight_postprocess");
  const std::vector<std::int32_t>& chars = td.part(part);
  GATCORE_CHECK(!chars.empty(), td.path, ": no characters to calibrate on (the ", dataset_part_name(part),
                " part is empty)");

  const std::size_t H = grid.heat_blends.size(), M = grid.min_weights.size();
  std::vector<double> l1(H * M, 0.0), dominant(H * M, 0.0);
  for (const std::int32_t c : chars) {
    const PreparedCharacter& pc = td.characters[std::size_t(c)];
    // The mix's bone heat: the baseline's own settings, as gat eval --heat-blend.
    BoneHeatParams bp;
    bp.max_influences = max_influences;
    const SkinWeights own = predict_skin_weights_any(model, norm, pc, max_influences);
    const std::vector<CalibrationPoint> points =
        score_postprocess_grid(td, c, own, bone_heat_weights(pc.character, bp), grid, max_influences);
    for (std::size_t i = 0; i < H * M; ++i) l1[i] += points[i].l1, dominant[i] += points[i].dominant;
  }
  WeightCalibration out;
  out.characters = int(chars.size());
  const double n = double(chars.size());
  bool first = true;
  for (std::size_t h = 0; h < H; ++h)
    for (std::size_t m = 0; m < M; ++m) {
      CalibrationPoint p;
      p.postprocess = {grid.min_weights[m], grid.heat_blends[h]};
      p.l1 = l1[h * M + m] / n;
      p.dominant = dominant[h * M + m] / n;
      out.grid.push_back(p);
      if (p.postprocess.min_weight == 0.0f && p.postprocess.heat_blend == 0.0f) out.raw = p;
      if (first || p.l1 < out.chosen.l1) out.chosen = p, first = false;
    }
  return out;
}

WeightCalibration calibrate_checkpoint(const std::string& path, const std::string& out, const std::string& data,
                                       DatasetPart part, const CalibrationGrid& grid, const ProgressFn& progress) {
  models::LoadedModel l = models::load_checkpoint(path);
  GATCORE_CHECK(l.model->config().task == models::Task::weights && models::any_skeleton(l.model->config().kind()), path,
                ": a ", l.model->config().name,
                " checkpoint; calibration chooses skinweights-any's post-processing (a model trained with gat train "
                "--model skinweights-any)");
  ModelDescription d = read_model_description(l.file, path);
  const std::string from = data.empty() ? d.data_path : data;
  GATCORE_CHECK(!from.empty(), path, ": the checkpoint records no dataset (data_path); give the dataset to calibrate on");
  const TrainingData td = load_training_data(from, progress);
  models::CheckpointFile file = l.file;  // before folding: the written tensors are the file's own
  l.model->fold_batch_norm();
  const WeightCalibration c = calibrate_weight_postprocess(td, part, *l.model, l.norm, grid);
  d.postprocess = c.chosen.postprocess;
  for (auto& [key, value] : model_description_metadata(d)) file.metadata[key] = value;
  models::write_checkpoint_file(out, file);
  return c;
}

}  // namespace gatcore::character
