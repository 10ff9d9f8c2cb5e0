#pragma once
// `gat eval --baseline bone-heat --data DATASET`: NeuroSkinning's per-character
// skin-weight table for a classical method (no model) on a dataset's
// characters, so baselines and models share one protocol. Called by cmd_eval.
#include <string>

namespace gat {
int eval_weight_baseline(const std::string& method, const std::string& data, const std::string& part, long poses,
                         long seed, double min_weight, const std::string& json_path);
}
