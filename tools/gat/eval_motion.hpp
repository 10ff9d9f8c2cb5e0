#pragma once
// `gat eval --motion M.bvh ...` / `--targets`: the options of the motion
// evaluation (character/eval/motion_eval.hpp, which computes the tables),
// its log, tables and files. Called by gat eval (cmd_eval.cpp, which declares
// the options) when --motion or --targets is given.
#include <string>
#include <vector>

namespace gat {

struct EvalMotionArgs {
  std::vector<std::string> motions, models, loss_curves;  // models: [LABEL=]FILE
  std::string data, part = "test", json, markdown, errormaps;
  long stride = 1, errormap_frames = 2, errormap_size = 320;
  double cm_per_unit = -1;  // unknown: from the file type
  double max_limit_excess_deg = -1;  // < 0: every frame; else frames further outside the joint limits are left out
  bool linear_probe = false;         // also the least-squares linear map of the input columns (the probe)
  bool targets = false;              // the characters' file targets (no --motion needed)
  bool quiet = false;
};

int eval_motion(const EvalMotionArgs& args);

}  // namespace gat
