#pragma once
// `gat eval --baseline bone-heat --data DATASET` and `gat eval --model
// skinweights-any.gcm --data DATASET`: NeuroSkinning's per-character
// skin-weight table for a method that works on each character's own joints
// (a classical method, or the skeleton-agnostic model), so baselines and
// models share one protocol. Called by cmd_eval.
#include <string>

#include "gatcore/models/checkpoint.hpp"

#include <vector>

#include "gatcore/character/eval/weight_eval.hpp"

namespace gat {
// Prints the per-character Markdown table and its legend, and writes the JSON
// when json_path is set (shared with cmd_eval's super-skeleton models); with
// confusions > 0, each character's largest dominant-bone confusions too.
void print_weight_table(const std::vector<gatcore::character::CharacterWeightEval>& per,
                        const gatcore::character::WeightEvalOptions& eo, const std::string& method,
                        const std::string& json_path, int confusions = 0);
// model: null for a baseline (method "bone-heat"), else a skinweights-any
// checkpoint, whose weights heat_blend > 0 mixes with bone heat's
// (rig/blend_weights.hpp; the method is then reported as
// "skinweights-any+heatS").
int eval_weight_baseline(const std::string& method, const std::string& data, const std::string& part, long poses,
                         long seed, double min_weight, const std::string& json_path, bool quiet, int confusions = 0,
                         gatcore::models::LoadedModel* model = nullptr, float heat_blend = 0.0f);
}
