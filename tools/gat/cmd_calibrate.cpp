// `gat calibrate MODEL [-o OUT]`: chooses a skinweights-any checkpoint's
// post-processing (heat blend, min weight) on the validation characters of
// the dataset it was trained on and records it in the checkpoint
// (character::calibrate_checkpoint); gat predict-weights, gat eval and the
// runtime then apply it unless told otherwise.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli_options.hpp"
#include "commands.hpp"
#include "gatcore/character/eval/weight_calibration.hpp"
#include "progress.hpp"

using namespace gatcore;

namespace gat {

namespace {

struct CalibrateArgs {
  std::string model, out, data, part = "validation";
  std::vector<float> min_weights, heat_blends;
  CommonOptions common;
};

int run_calibrate(const CalibrateArgs& a) {
  apply_threads(a.common);
  character::CalibrationGrid grid;
  if (!a.min_weights.empty()) grid.min_weights = a.min_weights;
  if (!a.heat_blends.empty()) grid.heat_blends = a.heat_blends;
  const std::string out = a.out.empty() ? a.model : a.out;
  const auto part = a.part == "train" ? character::DatasetPart::train : character::DatasetPart::validation;
  Progress loading("preparing the characters", 0, "characters", a.common.quiet);
  Activity doing("calibrating " + a.model);
  const character::WeightCalibration c =
      character::calibrate_checkpoint(a.model, out, a.data, part, grid, loading.callback());
  loading.finish();
  std::printf("gat calibrate: %s on %d %s characters: mean L1 per heat blend (rows) and min weight (columns)\n\n",
              a.model.c_str(), c.characters, a.part.c_str());
  std::printf("| heat blend |");
  for (const float m : grid.min_weights) std::printf(" %s |", number_text(double(m)).c_str());
  std::printf("\n|---:|");
  for (std::size_t m = 0; m < grid.min_weights.size(); ++m) std::printf("---:|");
  std::printf("\n");
  for (std::size_t h = 0; h < grid.heat_blends.size(); ++h) {
    std::printf("| %s |", number_text(double(grid.heat_blends[h])).c_str());
    for (std::size_t m = 0; m < grid.min_weights.size(); ++m)
      std::printf(" %.4f |", c.grid[h * grid.min_weights.size() + m].l1);
    std::printf("\n");
  }
  std::printf("\nchosen: heat blend %s, min weight %s: L1 %.4f, dominant bone %.3f (the model's own weights: L1 %.4f, "
              "dominant %.3f)\n-> %s\n",
              number_text(double(c.chosen.postprocess.heat_blend)).c_str(),
              number_text(double(c.chosen.postprocess.min_weight)).c_str(), c.chosen.l1, c.chosen.dominant, c.raw.l1,
              c.raw.dominant, out.c_str());
  return 0;
}

}  // namespace

Runner setup_calibrate(CLI::App& gat) {
  auto a = std::make_shared<CalibrateArgs>();
  CLI::App& c = add_command(gat, "calibrate", "choose a skinweights-any checkpoint's post-processing on held-out characters");
  set_details(c, "Scores every pair of heat blend (the model's weights mixed with bone heat's) and min weight "
                 "(influences below it dropped) on the validation characters of the dataset MODEL was trained on "
                 "(mean L1 over each character's own joints, top 4, as gat eval), and writes MODEL (or -o OUT) with "
                 "the lowest pair recorded. gat predict-weights, gat eval and the runtime (WeightPredictor, the C "
                 "API) apply it by default; their --heat-blend / --min-weight (set_heat_blend / set_min_weight) "
                 "override it. A softmax leaves small weights on every candidate bone where artists use about two "
                 "influences per vertex: the min weight removes them. Calibrate on characters of the training "
                 "families that were not trained on, never on the characters you will test on. Training the "
                 "checkpoint further (gat train --resume / --init) drops the calibration.");
  c.add_option("MODEL", a->model, "the skinweights-any checkpoint (.gcm)")->required();
  add_out(c, a->out, "write the calibrated checkpoint here (default: MODEL itself)");
  c.add_option("--data", a->data, "the dataset (default: the one MODEL was trained on)");
  c.add_option("--part", a->part, "which of its characters: validation (default) or train")
      ->check(one_of({"validation", "train"}));
  c.add_option("--min-weights", a->min_weights, "the min weights tried (comma-separated, in [0, 1), including 0; "
                                                 "default 0,0.01,0.02,0.03,0.05,0.075,0.1,0.15,0.2)")
      ->delimiter(',')
      ->check(number_in(0, 0.999));
  c.add_option("--heat-blends", a->heat_blends,
               "the heat blends tried (comma-separated, in [0, 1], including 0; default 0,0.1,0.2,0.3,0.5)")
      ->delimiter(',')
      ->check(number_in(0, 1));
  add_quiet(c, a->common);
  add_threads(c, a->common);
  return [a] { return run_calibrate(*a); };
}

}  // namespace gat
