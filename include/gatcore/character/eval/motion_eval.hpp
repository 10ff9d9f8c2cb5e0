#pragma once
// The DenseGATs-style evaluation of displacement models on motion: each
// model, the LBS and DQS baselines and (optionally) the linear probe against
// the dataset's reference deformer (Delta Mush / ARAP on LBS, or the
// characters' file targets), on every K-th frame of motions retargeted onto
// the characters of a dataset part. Per-vertex distance statistics per
// character and motion, per character and overall, as a Markdown table and
// JSON (gat eval --motion / --targets prints and writes them), and error
// colour maps of a few frames.
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/progress.hpp"

namespace gatcore::character {

struct MotionEvalOptions {
  std::string data;                                        // the dataset
  std::string part = "test";                               // train | validation | test
  std::vector<Motion> motions;                             // retargeted onto each character without file targets
  std::vector<std::string> motion_paths;                   // their files, for the JSON
  std::vector<std::pair<std::string, std::string>> models; // label ("" = the model's name), checkpoint file
  long stride = 1;                                         // every stride-th frame
  std::string errormaps;                                   // error colour maps into this folder ("" = none)
  long errormap_frames = 2, errormap_size = 320;
  double cm_per_unit = -1;             // unknown: 100 for glTF characters, else none
  double max_limit_excess_deg = -1;    // >= 0: frames further outside the dataset's joint limits are left out
  bool linear_probe = false;           // also the least-squares linear map of the input columns
};

// What the evaluation reports while it runs; each may be empty.
struct MotionEvalHooks {
  // Reading the dataset's characters: `done` of `total`.
  ProgressFn loading;
  // `done` of `total` frames; `note`: the character being evaluated.
  std::function<void(std::int64_t done, std::int64_t total, const std::string& note)> progress;
  // A line of the run's log (a linear probe fitted), without the newline.
  std::function<void(const std::string& line)> log;
  // A character and motion done: its line (frames, vertices, each method's mean), without the newline.
  std::function<void(const std::string& line)> row;
  // A warning (a character lacking bones every training character had).
  std::function<void(const std::string& warning)> warn;
};

struct MotionEvalReport {
  std::vector<std::string> methods;  // LBS, DQS, each model, each probe
  std::size_t characters = 0;
  std::string markdown;  // the tables
  std::string json;      // format "gatcore-eval-motion", version 1
  double seconds = 0;
};

// Throws InvalidArgument naming the file or option at fault (a dataset part
// without characters, a model for skin weights or of another skeleton, ...).
MotionEvalReport evaluate_motions(const MotionEvalOptions& o, const MotionEvalHooks& hooks = {});

}  // namespace gatcore::character
