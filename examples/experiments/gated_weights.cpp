// Two ways to combine skinweights-any with bone heat,
// measured before either goes in the library (docs/experiments/skin-weights.md):
//   gated_weights DATASET.json MODEL.gcm
// - a confidence gate: where the model's largest candidate probability at a
//   vertex is below a threshold, the vertex takes bone heat's weights; the
//   threshold, the heat blend and the min weight are chosen together on the
//   dataset's validation characters (gat calibrate's grid for the last two);
// - the correction scaled: heat + s * (model - heat), s in [0, 4], negative
//   weights dropped and the top 4 renormalised (s < 1 is a heat blend of 1 - s;
//   s > 1 pushes further from bone heat than the model does), the min weight
//   chosen on the validation characters.
// The test characters are then scored with gat eval's metric, and each one's
// mean largest candidate probability is printed beside the validation and
// test means.
#include <algorithm>
#include <cstdio>
#include <vector>

#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/weight_calibration.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/predict.hpp"
#include "gatcore/models/sample.hpp"

using namespace gatcore;
using namespace gatcore::character;

// heat + s * (model - heat) per vertex over the character's J joints, negative
// weights dropped, the largest 4 renormalised.
static SkinWeights scaled_correction(const SkinWeights& model, const SkinWeights& heat, std::int32_t J, float s) {
  const std::vector<float> a = model.dense(J), b = heat.dense(J);
  SkinWeights out;
  out.ptr.assign(1, 0);
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (const float x = b[i] + s * (a[i] - b[i]); x > 0)
      out.joint.push_back(std::int32_t(i % std::size_t(J))), out.weight.push_back(x);
    if ((i + 1) % std::size_t(J) == 0) out.ptr.push_back(std::int64_t(out.joint.size()));
  }
  return limit_weights(out, 4);
}

// Rows of `a`, except where `take_b` is set: rows of `b`.
static SkinWeights select_rows(const SkinWeights& a, const SkinWeights& b, const std::vector<char>& take_b) {
  SkinWeights out;
  out.ptr.assign(1, 0);
  for (std::size_t v = 0; v + 1 < a.ptr.size(); ++v) {
    const SkinWeights& s = take_b[v] ? b : a;
    for (std::int64_t i = s.ptr[v]; i < s.ptr[v + 1]; ++i)
      out.joint.push_back(s.joint[std::size_t(i)]), out.weight.push_back(s.weight[std::size_t(i)]);
    out.ptr.push_back(std::int64_t(out.joint.size()));
  }
  return out;
}

int main(int argc, char** argv) {
  if (argc != 3) { std::fprintf(stderr, "usage: %s dataset.json model.gcm\n", argv[0]); return 2; }
  const TrainingData td = load_training_data(argv[1]);
  models::LoadedModel m = models::load_checkpoint(argv[2]);
  m.model->fold_batch_norm();
  const int k = int(m.model->config().out_dim);
  const BoneHeatParams prior = prior_bone_heat(m.model->config());
  const CalibrationGrid grid;
  const std::vector<float>&mins = grid.min_weights, &blends = grid.heat_blends;
  const std::vector<float> gates{0.0f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.01f};
  const std::size_t G = gates.size() * blends.size() * mins.size();
  const std::vector<float> scales{0.0f, 0.25f, 0.5f, 0.75f, 1.0f, 1.25f, 1.5f, 2.0f, 3.0f, 4.0f};
  CalibrationGrid mins_only = grid;
  mins_only.heat_blends = {0.0f};
  const std::size_t S = scales.size() * mins.size();
  auto run_part = [&](DatasetPart part, std::vector<double>& l1, std::vector<double>& dom, std::vector<double>& gated,
                      std::vector<double>& scaled, double& confidence_mean,
                      std::vector<std::vector<double>>* per_char) {
    const auto& chars = td.part(part);
    l1.assign(G, 0.0), dom.assign(G, 0.0), gated.assign(gates.size(), 0.0), scaled.assign(S, 0.0);
    confidence_mean = 0;
    for (const std::int32_t ci : chars) {
      const PreparedCharacter& pc = td.characters[std::size_t(ci)];
      BoneCandidates c;
      const models::Sample sample = bone_candidate_sample(pc, k, prior, &c);
      const Tensor y = models::predict(*m.model, sample, m.norm, 0);
      const SkinWeights top = weights_from_candidates(c, models::top_k_renormalise(y, 4));
      BoneHeatParams bp;
      const SkinWeights heat = bone_heat_weights(pc.character, bp);
      std::vector<float> confidence(std::size_t(y.rows()), 0.0f);  // each vertex's largest candidate probability
      for (std::int64_t v = 0; v < y.rows(); ++v)
        for (std::int64_t j = 0; j < y.cols(); ++j)
          confidence[std::size_t(v)] = std::max(confidence[std::size_t(v)], y.at(v, j));
      double mean = 0;
      for (const float p : confidence) mean += p / double(confidence.size());
      confidence_mean += mean / double(chars.size());
      std::vector<double> row(G + 1, 0.0);
      row[G] = mean;
      for (std::size_t gi = 0; gi < gates.size(); ++gi) {
        std::vector<char> take(confidence.size(), 0);
        std::size_t n = 0;
        for (std::size_t v = 0; v < confidence.size(); ++v)
          if (confidence[v] < gates[gi]) take[v] = 1, ++n;
        gated[gi] += double(n) / double(y.rows()) / double(chars.size());
        const std::vector<CalibrationPoint> points =
            score_postprocess_grid(td, ci, select_rows(top, heat, take), heat, grid);
        for (std::size_t i = 0; i < points.size(); ++i) {
          const std::size_t g = gi * points.size() + i;
          l1[g] += points[i].l1 / double(chars.size());
          dom[g] += points[i].dominant / double(chars.size());
          row[g] = points[i].l1;
        }
      }
      if (per_char) per_char->push_back(row);
      for (std::size_t si = 0; si < scales.size(); ++si) {
        const SkinWeights w = scaled_correction(top, heat, pc.character.skeleton.num_joints(), scales[si]);
        const std::vector<CalibrationPoint> points = score_postprocess_grid(td, ci, w, heat, mins_only);
        for (std::size_t i = 0; i < points.size(); ++i) scaled[si * mins.size() + i] += points[i].l1 / double(chars.size());
      }
      std::fprintf(stderr, ".");
    }
  };
  std::vector<double> vl1, vdom, vg, vs, tl1, tdom, tg, ts;
  double vconf = 0, tconf = 0;
  std::vector<std::vector<double>> tchar;
  run_part(DatasetPart::validation, vl1, vdom, vg, vs, vconf, nullptr);
  run_part(DatasetPart::test, tl1, tdom, tg, ts, tconf, &tchar);
  std::fprintf(stderr, "\n");
  const std::size_t per_gate = blends.size() * mins.size();
  std::size_t best = 0, best0 = 0;
  for (std::size_t g = 0; g < G; ++g) if (vl1[g] < vl1[best]) best = g;
  for (std::size_t g = 0; g < per_gate; ++g) if (vl1[g] < vl1[best0]) best0 = g;
  std::printf("chosen: gate %.2f blend %.2g min %.3g: val %.4f test %.4f dom %.3f | no gate: val %.4f test %.4f dom %.3f\n",
              double(gates[best / per_gate]), double(blends[(best % per_gate) / mins.size()]),
              double(mins[best % mins.size()]), vl1[best], tl1[best], tdom[best], vl1[best0], tl1[best0], tdom[best0]);
  std::printf("per gate (best blend/min on validation): gate val-share test-share val test dom\n");
  for (std::size_t gi = 0; gi < gates.size(); ++gi) {
    std::size_t b = gi * per_gate;
    for (std::size_t g = gi * per_gate; g < (gi + 1) * per_gate; ++g) if (vl1[g] < vl1[b]) b = g;
    std::printf("  %.2f %.3f %.3f %.4f %.4f %.3f\n", double(gates[gi]), vg[gi], tg[gi], vl1[b], tl1[b], tdom[b]);
  }
  std::printf("test per character, L1 at chosen / no gate (mean largest candidate probability; validation %.3f, "
              "test %.3f):",
              vconf, tconf);
  for (const auto& r : tchar) std::printf(" %.3f/%.3f (%.2f)", r[best], r[best0], r[G]);
  std::printf("\n");
  std::printf("correction scaled (min weight best on validation): scale min val test\n");
  for (std::size_t si = 0; si < scales.size(); ++si) {
    std::size_t b = si * mins.size();
    for (std::size_t g = b; g < (si + 1) * mins.size(); ++g) if (vs[g] < vs[b]) b = g;
    std::printf("  %.2f %.3g %.4f %.4f\n", double(scales[si]), double(mins[b % mins.size()]), vs[b], ts[b]);
  }
  return 0;
}
