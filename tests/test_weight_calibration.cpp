// The calibrated post-processing of skinweights-any (character/eval/
// weight_calibration.hpp): every grid point is gat eval's figure for that
// heat blend and min weight, the chosen one is the lowest, the checkpoint
// records it (ModelDescription) with its tensors untouched, and the runtime
// applies it by default.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/own_joint_weight_eval.hpp"
#include "gatcore/character/eval/weight_calibration.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/runtime.hpp"
#include "small_dataset.hpp"

using namespace gatcore;
using namespace gatcore::character;
namespace fs = std::filesystem;

namespace {

models::ModelConfig small_any_config() {
  models::ModelConfig c = models::ModelConfig::defaults("skinweights-any", bone_candidate_feature_dim(kDefaultCandidates),
                                                        kDefaultCandidates);
  c.stage1 = {16, 8}, c.gc_dims = {8, 8, 8}, c.global_mlp = {16}, c.classifier = {16};
  return c;
}

// Moves the model away from its prior (an untrained skinweights-any is bone
// heat over its candidates): random last-layer weights.
void perturb(models::Model& m) {
  nn::Rng rng(11);
  for (const Var& p : m.parameters()) {
    Tensor t = p.value();
    for (std::int64_t i = 0; i < t.numel(); ++i) t.data()[i] += 0.5f * (rng.uniform() - 0.5f);
  }
}

double mean_l1(const std::vector<CharacterWeightEval>& per) {
  double s = 0;
  for (const auto& r : per) s += r.weights.l1_mean;
  return s / double(per.size());
}

}  // namespace

TEST_CASE("weight calibration: every grid point is gat eval's figure, the lowest is chosen") {
  const fs::path dir = fs::temp_directory_path() / "gatcore_test_weight_calibration";
  const std::string data = testing::write_small_dataset(dir);
  const TrainingData td = load_training_data(data);
  auto model = models::make_model(small_any_config(), 3);
  perturb(*model);
  model->fold_batch_norm();
  const models::Normaliser norm;
  CalibrationGrid grid;
  grid.min_weights = {0.0f, 0.05f, 0.2f};
  grid.heat_blends = {0.0f, 0.4f};
  const WeightCalibration c = calibrate_weight_postprocess(td, DatasetPart::train, *model, norm, grid);
  CHECK(c.characters == int(td.part(DatasetPart::train).size()));
  REQUIRE(c.grid.size() == 6);
  WeightEvalOptions eo;
  eo.poses = 0;
  double lowest = 1e9;
  for (std::size_t h = 0; h < 2; ++h)
    for (std::size_t m = 0; m < 3; ++m) {
      const CalibrationPoint& p = c.grid[h * 3 + m];
      CHECK(p.postprocess.heat_blend == grid.heat_blends[h]);
      CHECK(p.postprocess.min_weight == grid.min_weights[m]);
      OwnJointMethod how;
      how.model = model.get();
      how.norm = &norm;
      how.heat_blend = grid.heat_blends[h];
      eo.min_weight = grid.min_weights[m];
      const auto per = evaluate_own_joint_weights(td, DatasetPart::train, how, eo);
      CHECK(p.l1 == Approx(mean_l1(per)).epsilon(1e-12));
      lowest = std::min(lowest, p.l1);
    }
  CHECK(c.chosen.l1 == lowest);
  CHECK(c.raw.postprocess.min_weight == 0.0f);
  CHECK(c.raw.postprocess.heat_blend == 0.0f);
  CHECK(c.raw.l1 == c.grid[0].l1);
  // Pruning and mixing change the figure (the grid is not degenerate).
  CHECK(c.grid[2].l1 != c.grid[0].l1);
  CHECK(c.grid[3].l1 != c.grid[0].l1);
}

TEST_CASE("weight calibration: bad grids and empty parts are refused") {
  const fs::path dir = fs::temp_directory_path() / "gatcore_test_weight_calibration_bad";
  const TrainingData td = load_training_data(testing::write_small_dataset(dir));
  auto model = models::make_model(small_any_config(), 3);
  model->fold_batch_norm();
  const models::Normaliser norm;
  CalibrationGrid g;
  g.min_weights = {0.05f, 0.1f};
  CHECK_THROWS_WITH(calibrate_weight_postprocess(td, DatasetPart::train, *model, norm, g),
                    Catch::Contains("must include min weight 0"));
  g = {};
  g.min_weights = {0.0f, 1.0f};
  CHECK_THROWS_WITH(calibrate_weight_postprocess(td, DatasetPart::train, *model, norm, g),
                    Catch::Contains("min weight must be in [0, 1)"));
  g = {};
  g.heat_blends = {0.0f, 1.5f};
  CHECK_THROWS_WITH(calibrate_weight_postprocess(td, DatasetPart::train, *model, norm, g),
                    Catch::Contains("heat blend must be in [0, 1]"));
  TrainingData empty = td;
  empty.description.split.validation.clear();
  CHECK_THROWS_WITH(calibrate_weight_postprocess(empty, DatasetPart::validation, *model, norm),
                    Catch::Contains("validation part is empty"));
  const auto n = static_cast<std::int32_t>(td.characters.size());
  CHECK_THROWS_WITH(score_postprocess_grid(td, n, SkinWeights{}, SkinWeights{}, CalibrationGrid{}),
                    Catch::Contains("character " + std::to_string(n) + " of"));
  CHECK_THROWS_WITH(score_postprocess_grid(td, 0, SkinWeights{}, SkinWeights{}, CalibrationGrid{}),
                    Catch::Contains("the weights have 0"));
  const SkinWeights own = td.characters[0].character.mesh.weights;
  g = {};
  g.heat_blends = {0.0f, 2.0f};
  CHECK_THROWS_WITH(score_postprocess_grid(td, 0, own, own, g), Catch::Contains("heat blend must be in [0, 1]"));
  CHECK(score_postprocess_grid(td, 0, own, own, CalibrationGrid{}).size() ==
        CalibrationGrid{}.heat_blends.size() * CalibrationGrid{}.min_weights.size());
}

TEST_CASE("weight calibration: the checkpoint records it, keeps its tensors, and the runtime applies it") {
  const fs::path dir = fs::temp_directory_path() / "gatcore_test_weight_calibration_file";
  const std::string data = testing::write_small_dataset(dir);
  auto model = models::make_model(small_any_config(), 3);
  perturb(*model);
  ModelDescription d;
  d.features = FeatureKind::bone_candidates;
  d.data_path = fs::absolute(data).string();
  d.data_hash = file_hash(data);
  const std::string in = (dir / "any.gcm").string(), out = (dir / "any.calibrated.gcm").string();
  models::save_checkpoint(in, *model, models::Normaliser{}, model_description_metadata(d));
  CHECK_FALSE(read_model_description(models::read_checkpoint_file(in), in).postprocess);

  CalibrationGrid grid;
  grid.min_weights = {0.0f, 0.05f, 0.2f};
  grid.heat_blends = {0.0f, 0.4f};
  const WeightCalibration c = calibrate_checkpoint(in, out, "", DatasetPart::validation, grid);
  CHECK(c.characters == 1);
  const models::CheckpointFile a = models::read_checkpoint_file(in), b = models::read_checkpoint_file(out);
  const auto pp = read_model_description(b, out).postprocess;
  REQUIRE(pp);
  CHECK(pp->min_weight == c.chosen.postprocess.min_weight);
  CHECK(pp->heat_blend == c.chosen.postprocess.heat_blend);
  // Every tensor byte for byte; only the two metadata keys added.
  REQUIRE(a.tensors.size() == b.tensors.size());
  for (std::size_t i = 0; i < a.tensors.size(); ++i) {
    const Tensor* t = b.find(a.tensors[i].first);
    REQUIRE(t);
    REQUIRE(t->numel() == a.tensors[i].second.numel());
    CHECK(std::memcmp(t->data(), a.tensors[i].second.data(), std::size_t(t->numel()) * sizeof(float)) == 0);
  }
  for (const auto& [k, v] : a.metadata)
    if (k != "checksum") CHECK(b.metadata.at(k) == v);
  CHECK(b.metadata.size() == a.metadata.size() + 2);

  // The runtime's defaults are the calibration; the setters override them.
  runtime::WeightPredictor p = runtime::WeightPredictor::load(out);
  CHECK(p.min_weight() == pp->min_weight);
  CHECK(p.heat_blend() == pp->heat_blend);
  runtime::WeightPredictor raw = runtime::WeightPredictor::load(in);
  CHECK(raw.min_weight() == 0.0f);
  CHECK(raw.heat_blend() == 0.0f);

  // Calibrating in place works too; a model of another kind is refused, naming the file.
  CHECK_NOTHROW(calibrate_checkpoint(in, in, data, DatasetPart::validation, grid));
  CHECK(read_model_description(models::read_checkpoint_file(in), in).postprocess);
  auto ns = models::make_model(models::ModelConfig::defaults("neuroskinning", 12, 4), 3);
  const std::string other = (dir / "ns.gcm").string();
  models::save_checkpoint(other, *ns, models::Normaliser{}, {{"data_path", d.data_path}});
  CHECK_THROWS_WITH(calibrate_checkpoint(other, out, "", DatasetPart::validation),
                    Catch::Contains(other) && Catch::Contains("skinweights-any"));
}

TEST_CASE("model description: the post-processing keys are read strictly and together") {
  ModelDescription d;
  d.features = FeatureKind::bone_candidates;
  d.postprocess = WeightPostprocess{0.05f, 0.2f};
  models::CheckpointFile f;
  f.metadata = model_description_metadata(d);
  const ModelDescription back = read_model_description(f, "x.gcm");
  REQUIRE(back.postprocess);
  CHECK(back.postprocess->min_weight == 0.05f);
  CHECK(back.postprocess->heat_blend == 0.2f);
  CHECK(f.metadata.at("min_weight") == "0.05");  // the shortest text of the float
  CHECK(f.metadata.at("heat_blend") == "0.2");
  models::CheckpointFile g = f;
  g.metadata.erase("heat_blend");
  CHECK_THROWS_WITH(read_model_description(g, "x.gcm"), Catch::Contains("x.gcm") && Catch::Contains("heat_blend"));
  g = f;
  g.metadata["min_weight"] = "1.5";
  CHECK_THROWS_WITH(read_model_description(g, "x.gcm"), Catch::Contains("min_weight"));
  g = f;
  g.metadata["heat_blend"] = "nan";
  CHECK_THROWS_WITH(read_model_description(g, "x.gcm"), Catch::Contains("heat_blend"));
}
