// The motion evaluation harness (character/eval/motion_eval.hpp) on a small
// procedural dataset, the procedural swing and an untrained DenseGATs:
// the tables' shape and counts, the JSON, the frame rules (stride, joint
// limits), the hooks, and the refusals.
#include <catch2/catch.hpp>

#include <filesystem>

#include <nlohmann/json.hpp>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/dataset_model_description.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/motion_eval.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model.hpp"
#include "small_dataset.hpp"

using namespace gatcore;
using namespace gatcore::character;
namespace fs = std::filesystem;

namespace {

struct Fixture {
  fs::path dir = fs::temp_directory_path() / "gatcore_test_motion_eval";
  std::string data, model, weights_model;
  Motion swing = parse_bvh(procedural_swing_bvh(), "swing.bvh");
  Fixture() {
    data = testing::write_small_dataset(dir);
    const TrainingData td = load_training_data(data);
    // An untrained DenseGATs on the dataset's bone columns, described as gat train would.
    models::ModelConfig cfg = models::ModelConfig::defaults("densegats", td.feature_dim(models::Task::displacement));
    cfg.modules = 1, cfg.blocks = 1, cfg.head = {16};
    auto m = models::make_model(cfg, 1);
    model = (dir / "dg.gcm").string();
    models::save_checkpoint(model, *m, {}, model_description_metadata(describe_dataset_model(td, data, cfg, {})));
    models::ModelConfig wc = models::ModelConfig::defaults("neuroskinning", td.feature_dim(models::Task::weights),
                                                            td.super.num_bones());
    auto w = models::make_model(wc, 1);
    weights_model = (dir / "ns.gcm").string();
    models::save_checkpoint(weights_model, *w, {},
                            model_description_metadata(describe_dataset_model(td, data, wc, {})));
  }
  MotionEvalOptions options(long stride) const {
    MotionEvalOptions o;
    o.data = data;
    o.motions = {swing};
    o.motion_paths = {"swing.bvh"};
    o.models = {{"small", model}};
    o.stride = stride;
    return o;
  }
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

}  // namespace

TEST_CASE("motion eval: LBS, DQS and a model on every K-th frame of the test characters") {
  const Fixture& f = fixture();
  std::int64_t progress_calls = 0, last_total = 0;
  std::vector<std::string> rows;
  MotionEvalHooks hooks;
  hooks.progress = [&](std::int64_t, std::int64_t total, const std::string&) { ++progress_calls, last_total = total; };
  hooks.row = [&](const std::string& line) { rows.push_back(line); };
  const MotionEvalReport r = evaluate_motions(f.options(4), hooks);
  CHECK(r.methods == std::vector<std::string>{"LBS", "DQS", "small"});
  CHECK(r.characters == 1);  // 4 characters at test 0.25
  const std::int64_t frames = (std::int64_t(f.swing.clip.frames.size()) + 3) / 4;
  CHECK(progress_calls == frames);
  CHECK(last_total == frames);
  REQUIRE(rows.size() == 1);
  CHECK_THAT(rows[0], Catch::Contains(std::to_string(frames) + " frames x"));
  const auto j = nlohmann::json::parse(r.json);
  CHECK(j.at("format") == "gatcore-eval-motion");
  CHECK(j.at("stride") == 4);
  CHECK(j.at("methods").size() == 3);
  REQUIRE(j.at("rows").size() == 2);  // the character and motion, the character overall
  for (const auto& row : j.at("rows")) {
    CHECK(row.at("frames") == frames);
    for (const char* m : {"LBS", "DQS", "small"}) {
      const auto& s = row.at("methods").at(m);
      CHECK(s.at("vertex_frames") == frames * row.at("vertices").get<std::int64_t>());
      CHECK(s.at("min").get<double>() <= s.at("mean").get<double>());
      CHECK(s.at("mean").get<double>() <= s.at("max").get<double>());
    }
  }
  // The swing bends the body, so Delta Mush differs from LBS; DQS is another deformation again.
  const auto& overall = j.at("overall");
  CHECK(overall.at("LBS").at("mean").get<double>() > 0);
  CHECK(overall.at("DQS").at("mean").get<double>() != overall.at("LBS").at("mean").get<double>());
  CHECK_THAT(r.markdown, Catch::Contains("| method | mean | p99 | max | min |") && Catch::Contains("| small |"));

  // Every frame: twice... four times the frames, the same characters.
  const MotionEvalReport all = evaluate_motions(f.options(1));
  CHECK(nlohmann::json::parse(all.json).at("rows").at(0).at("frames") == std::int64_t(f.swing.clip.frames.size()));
}

TEST_CASE("motion eval: frames outside the joint limits are left out and counted") {
  const Fixture& f = fixture();
  MotionEvalOptions o = f.options(2);
  o.max_limit_excess_deg = 0;
  const auto j = nlohmann::json::parse(evaluate_motions(o).json);
  const auto& row = j.at("rows").at(0);
  const std::int64_t kept = row.at("frames"), left_out = row.at("frames_excluded");
  CHECK(kept + left_out == (std::int64_t(f.swing.clip.frames.size()) + 1) / 2);
  CHECK(left_out > 0);  // the swing leaves the dataset's +-0.5 rad limits somewhere
}

TEST_CASE("motion eval: refusals name the file or option") {
  const Fixture& f = fixture();
  MotionEvalOptions o = f.options(4);
  o.models = {{"", f.weights_model}};
  CHECK_THROWS_WITH(evaluate_motions(o), Catch::Contains("ns.gcm") && Catch::Contains("predicts skin weights"));
  o = f.options(4);
  o.data.clear();
  CHECK_THROWS_WITH(evaluate_motions(o), Catch::Contains("--data"));
  o = f.options(4);
  o.part = "validation";
  CHECK(evaluate_motions(o).characters == 1);
}
