#pragma once
// The post-processing of a skin-weight model's weights (a heat blend, then a
// min weight: inference/model_description.hpp's WeightPostprocess), chosen
// on held-out characters of the training families: each pair of a grid is
// scored by the mean L1 of gat eval's protocol (the characters' own joints,
// top k) and the lowest wins. A softmax leaves small weights on every
// candidate bone where artists use about two influences per vertex, and how
// much to trust the model against bone heat is a property of the model and
// its training families, not of a test character: both are calibrated once,
// on the validation part, and stored in the checkpoint (gat calibrate).
#include <string>
#include <vector>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/models/model.hpp"

namespace gatcore::character {

struct CalibrationGrid {
  std::vector<float> min_weights{0.0f, 0.01f, 0.02f, 0.03f, 0.05f, 0.075f, 0.1f, 0.15f, 0.2f};
  std::vector<float> heat_blends{0.0f, 0.1f, 0.2f, 0.3f, 0.5f};
};

struct CalibrationPoint {
  WeightPostprocess postprocess;
  double l1 = 0;        // mean over the characters of their mean per-vertex L1
  double dominant = 0;  // mean dominant-bone accuracy
};

struct WeightCalibration {
  int characters = 0;
  CalibrationPoint chosen;  // the lowest L1 (ties: the earlier grid point, heat blends outer)
  CalibrationPoint raw;     // no post-processing (min weight 0, heat blend 0)
  std::vector<CalibrationPoint> grid;  // heat blends outer, min weights inner
};

// One character of `td` (its index `character`) at every point of `grid`
// (heat blends outer, min weights inner): its weights `own` mixed with bone
// heat's `heat` by the point's heat blend, then cut at its min weight, scored
// as gat eval scores them (the character's own joints, top max_influences).
// Throws InvalidArgument for a character out of range, weights of another
// vertex count, or a grid value out of range (as calibrate_weight_postprocess).
std::vector<CalibrationPoint> score_postprocess_grid(const TrainingData& td, std::int32_t character,
                                                     const SkinWeights& own, const SkinWeights& heat,
                                                     const CalibrationGrid& grid, int max_influences = 4);

// Scores every grid pair on the characters of `part` with a skinweights-any
// model (its batch norm folded) and its normaliser. The grid's values must lie
// in [0, 1) (min weights) and [0, 1] (heat blends), and include 0 each, so
// the model's own weights are a candidate. Throws InvalidArgument for an
// empty part, a grid without 0, a value out of range, or a model that is not
// skeleton-agnostic.
WeightCalibration calibrate_weight_postprocess(const TrainingData& td, DatasetPart part, models::Model& model,
                                               const models::Normaliser& norm, const CalibrationGrid& grid = {},
                                               int max_influences = 4);

// The whole job of gat calibrate: loads the skinweights-any checkpoint at
// `path`, calibrates it on `part` of `data` (empty: the dataset it was trained
// on, its description's data_path), and writes it to `out` (may be `path`;
// atomically) with the chosen post-processing in its description; every other
// byte of its contents is kept. `progress`: characters loaded of all. Throws
// InvalidArgument naming the file for a checkpoint that is not
// skinweights-any or has no dataset to calibrate on.
WeightCalibration calibrate_checkpoint(const std::string& path, const std::string& out, const std::string& data,
                                       DatasetPart part, const CalibrationGrid& grid = {},
                                       const ProgressFn& progress = {});

}  // namespace gatcore::character
