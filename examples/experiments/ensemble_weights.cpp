// Two post-processings of skinweights-any, measured before either goes in
// the library (docs/experiments/skin-weights.md):
//   ensemble_weights DATASET.json MODEL.gcm...
// - the ensemble: the candidates' probabilities of several checkpoints (other
//   seeds of one fold) averaged, against each checkpoint alone;
// - smoothing: each vertex's weights averaged with its mesh neighbours' 0-8
//   times before the top 4 are kept; sharpening: its candidates'
//   probabilities raised to a power (1.5, 2, 3) and renormalised.
// Each variant's post-processing (smoothing x heat blend x min weight, gat
// calibrate's grid) is chosen on the dataset's validation characters, then
// the test characters are scored with gat eval's metric (L1, dominant bone).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/weight_calibration.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"
#include "gatcore/models/predict.hpp"

using namespace gatcore;
using namespace gatcore::character;

// The candidates' probabilities of one checkpoint, on the character's
// sample (bone_candidate_sample), without the prior where the model takes none.
static Tensor probs(models::LoadedModel& l, const models::Sample& sample) {
  if (l.model->config().logit_prior) return models::predict(*l.model, sample, l.norm, 0);
  models::Sample s = sample;
  s.prior = Tensor{};
  return models::predict(*l.model, s, l.norm, 0);
}

// Each vertex's weights averaged with its mesh neighbours' `iters` times
// (half its own, half the neighbourhood mean), then its top 4 renormalised.
static SkinWeights smooth(const SkinWeights& w, const CsrGraph& g, std::int32_t J, int iters) {
  if (iters == 0) return w;
  std::vector<float> d = w.dense(J), t(d.size());
  const std::int64_t n = w.num_vertices();
  for (int it = 0; it < iters; ++it) {
    for (std::int64_t v = 0; v < n; ++v) {
      const std::int64_t b = g.indptr[v], e = g.indptr[v + 1];
      for (std::int32_t j = 0; j < J; ++j) {
        double m = 0;
        for (std::int64_t k = b; k < e; ++k) m += d[std::size_t(g.indices[k]) * J + j];
        t[std::size_t(v) * J + j] = float(0.5 * d[std::size_t(v) * J + j] + 0.5 * m / double(e - b));
      }
    }
    std::swap(d, t);
  }
  SkinWeights out;
  out.ptr.assign(1, 0);
  for (std::int64_t v = 0; v < n; ++v) {
    for (std::int32_t j = 0; j < J; ++j)
      if (d[std::size_t(v) * J + j] > 0) out.joint.push_back(j), out.weight.push_back(d[std::size_t(v) * J + j]);
    out.ptr.push_back(std::int64_t(out.joint.size()));
  }
  return limit_weights(out, 4);
}

int main(int argc, char** argv) {
  if (argc < 3) { std::fprintf(stderr, "usage: %s dataset.json model.gcm...\n", argv[0]); return 2; }
  const TrainingData td = load_training_data(argv[1]);
  std::vector<models::LoadedModel> ms;
  for (int i = 2; i < argc; ++i) { ms.push_back(models::load_checkpoint(argv[i])); ms.back().model->fold_batch_norm(); }
  const int M = int(ms.size()), k = int(ms[0].model->config().out_dim);
  // One sample per character serves every member: they must read the same features.
  const models::ModelConfig& first = ms[0].model->config();
  const BoneHeatParams heat = prior_bone_heat(first);
  for (int i = 1; i < M; ++i)
    if (const models::ModelConfig& c = ms[std::size_t(i)].model->config();
        c.out_dim != k || c.prior_weight_limit != first.prior_weight_limit ||
        c.prior_straight_chains != first.prior_straight_chains) {
      std::fprintf(stderr, "%s: its candidates or bone-heat prior differ from %s's\n", argv[i + 2], argv[2]);
      return 2;
    }
  const CalibrationGrid grid;  // gat calibrate's
  const std::vector<float>&mins = grid.min_weights, &blends = grid.heat_blends;
  // > 0: smoothing iterations; < 0: sharpening, each vertex's candidate
  // probabilities raised to the power -s/2 (1.5, 2, 3) and renormalised.
  const std::vector<int> smooths{0, 1, 2, 4, 8, -3, -4, -6};
  const std::size_t G = smooths.size() * blends.size() * mins.size();
  // variants: each single model, then the ensemble
  auto run_part = [&](DatasetPart part, std::vector<std::vector<double>>& l1, std::vector<std::vector<double>>& dom,
                      bool per_char) {
    const auto& chars = td.part(part);
    l1.assign(M + 1, std::vector<double>(G, 0.0));
    dom = l1;
    for (const std::int32_t ci : chars) {
      const PreparedCharacter& pc = td.characters[std::size_t(ci)];
      BoneCandidates c;
      const models::Sample sample = bone_candidate_sample(pc, k, heat, &c);
      std::vector<Tensor> ys;
      for (auto& m : ms) ys.push_back(probs(m, sample));
      Tensor avg = ys[0].clone();
      for (int m = 1; m < M; ++m)
        for (std::int64_t i = 0; i < avg.rows(); ++i)
          for (std::int64_t j = 0; j < avg.cols(); ++j) avg.at(i, j) += ys[m].at(i, j);
      for (std::int64_t i = 0; i < avg.rows(); ++i)
        for (std::int64_t j = 0; j < avg.cols(); ++j) avg.at(i, j) /= float(M);
      ys.push_back(avg);
      BoneHeatParams bp;
      const SkinWeights heat = bone_heat_weights(pc.character, bp);
      for (int v = 0; v <= M; ++v) {
        const SkinWeights full = weights_from_candidates(c, ys[v]);
        for (std::size_t si = 0; si < smooths.size(); ++si) {
          SkinWeights top;
          if (smooths[si] > 0) {
            top = smooth(full, pc.mesh_graph, pc.character.skeleton.num_joints(), smooths[si]);
          } else {
            Tensor y = ys[v].clone();
            if (smooths[si] < 0) {
              const float g = -0.5f * float(smooths[si]);
              for (std::int64_t i = 0; i < y.rows(); ++i) {
                double sum = 0;
                for (std::int64_t j = 0; j < y.cols(); ++j) sum += y.at(i, j) = std::pow(y.at(i, j), g);
                if (sum > 0)
                  for (std::int64_t j = 0; j < y.cols(); ++j) y.at(i, j) = float(y.at(i, j) / sum);
              }
            }
            top = weights_from_candidates(c, models::top_k_renormalise(y, 4));
          }
          const std::vector<CalibrationPoint> points = score_postprocess_grid(td, ci, top, heat, grid);
          for (std::size_t i = 0; i < points.size(); ++i) {
            const std::size_t gi = si * points.size() + i;
            l1[v][gi] += points[i].l1 / double(chars.size());
            dom[v][gi] += points[i].dominant / double(chars.size());
          }
        }
      }
      if (per_char) std::fprintf(stderr, ".");
    }
  };
  std::vector<std::vector<double>> vl1, vdom, tl1, tdom;
  run_part(DatasetPart::validation, vl1, vdom, false);
  run_part(DatasetPart::test, tl1, tdom, true);
  std::fprintf(stderr, "\n");
  for (int v = 0; v <= M; ++v) {
    std::size_t best = 0;
    for (std::size_t g = 0; g < vl1[v].size(); ++g) if (vl1[v][g] < vl1[v][best]) best = g;
    // The best without smoothing too (the grid's first block).
    std::size_t best0 = 0;
    for (std::size_t g = 0; g < blends.size() * mins.size(); ++g) if (vl1[v][g] < vl1[v][best0]) best0 = g;
    const std::size_t bm = best % (blends.size() * mins.size());
    std::printf("%s: val L1 %.4f (smooth %d blend %.2g min %.3g) test L1 %.4f dominant %.3f | unsmoothed: val %.4f "
                "test %.4f dom %.3f | raw test L1 %.4f dom %.3f\n",
                v < M ? argv[2 + v] : "ensemble", vl1[v][best], smooths[best / (blends.size() * mins.size())],
                double(blends[bm / mins.size()]), double(mins[bm % mins.size()]), tl1[v][best], tdom[v][best],
                vl1[v][best0], tl1[v][best0], tdom[v][best0], tl1[v][0], tdom[v][0]);
    // Test L1 per smoothing at the unsmoothed choice of blend and min weight.
    std::printf("   test L1 by smoothing (blend/min fixed):");
    for (std::size_t si = 0; si < smooths.size(); ++si)
      std::printf(" %d:%.4f/%.3f", smooths[si], tl1[v][si * blends.size() * mins.size() + best0],
                  tdom[v][si * blends.size() * mins.size() + best0]);
    std::printf("\n   val L1 by smoothing:");
    for (std::size_t si = 0; si < smooths.size(); ++si)
      std::printf(" %d:%.4f", smooths[si], vl1[v][si * blends.size() * mins.size() + best0]);
    std::printf("\n");
  }
  return 0;
}
