// turned_weights: does a skin-weight model give a character the same weights
// whichever way it faces? (docs/RESULTS.md.)
//
//   turned_weights DATASET.json MODEL.gcm [PART]
//
// For each character of PART (test, validation or train; default test) it
// turns the character a quarter, a half and three quarters about the
// vertical axis (mesh, bind matrices and root transforms together; the
// matrices hold only 0 and +-1, so nothing is rounded), predicts its top-4
// weights with the skinweights-any checkpoint each time, and prints the
// per-vertex L1 against the artist's weights (gat eval's metric, over the
// character's own joints) and the dominant-bone accuracy at each facing.
// A model that reads the vertex's world-frame position and normal (gat train
// --world-columns use) changes with the facing; one that ignores them
// (the default) gives the same figures at all four.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/metrics.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

// The character turned by `quarters` quarter turns about +y: positions, bind
// space (inverse bind matrices) and the roots' rest transforms move together.
Character turned(const Character& c, int quarters) {
  static const float cos_q[4] = {1, 0, -1, 0}, sin_q[4] = {0, 1, 0, -1};
  Mat4 t = mat4_identity();
  t[0] = t[10] = cos_q[quarters];
  t[8] = sin_q[quarters];
  t[2] = -sin_q[quarters];
  const Mat4 inv = inverse(t);
  Character out = c;
  for (std::size_t i = 0; i + 2 < c.mesh.positions.size(); i += 3) {
    const Vec3 p = transform_point(t, {c.mesh.positions[i], c.mesh.positions[i + 1], c.mesh.positions[i + 2]});
    for (std::size_t d = 0; d < 3; ++d) out.mesh.positions[i + d] = p[d];
  }
  for (std::size_t j = 0; j < c.skeleton.inverse_bind.size(); ++j) {
    out.skeleton.inverse_bind[j] = mul(c.skeleton.inverse_bind[j], inv);
    if (c.skeleton.parents[j] < 0) out.skeleton.root_parent[j] = mul(t, c.skeleton.root_parent[j]);
  }
  return out;
}

// Dense [n, joints] weights over the character's own joints (super_weights
// with the identity joint map).
std::vector<float> dense(const SkinWeights& w, std::int32_t joints) {
  std::vector<std::int32_t> identity(static_cast<std::size_t>(joints));
  for (std::int32_t j = 0; j < joints; ++j) identity[std::size_t(j)] = j;
  return super_weights(w, identity, joints);
}

double dominant_accuracy(const std::vector<float>& pred, const std::vector<float>& truth, std::int64_t n,
                         std::int32_t joints) {
  std::int64_t right = 0;
  for (std::int64_t v = 0; v < n; ++v) {
    std::int32_t a = 0, b = 0;  // the first of equal weights, as gat eval
    for (std::int32_t j = 1; j < joints; ++j) {
      if (pred[std::size_t(v * joints + j)] > pred[std::size_t(v * joints + a)]) a = j;
      if (truth[std::size_t(v * joints + j)] > truth[std::size_t(v * joints + b)]) b = j;
    }
    right += a == b;
  }
  return n > 0 ? double(right) / double(n) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: turned_weights DATASET.json MODEL.gcm [test|validation|train]\n");
    return 2;
  }
  try {
    const std::string part_name = argc > 3 ? argv[3] : "test";
    GATCORE_CHECK(part_name == "test" || part_name == "validation" || part_name == "train",
                  "PART must be test, validation or train, got '", part_name, "'");
    const DatasetPart part = part_name == "test"         ? DatasetPart::test
                             : part_name == "validation" ? DatasetPart::validation
                                                         : DatasetPart::train;
    const TrainingData td = load_training_data(argv[1]);
    models::LoadedModel lm = models::load_checkpoint(argv[2]);
    lm.model->fold_batch_norm();
    std::printf("| character | facing 0: L1 / dominant | a quarter turn | a half turn | three quarters |\n");
    std::printf("|---|---:|---:|---:|---:|\n");
    double l1_sum[4] = {0, 0, 0, 0}, dom_sum[4] = {0, 0, 0, 0};
    int count = 0;
    for (const std::int32_t c : td.part(part)) {
      const Character& ch = td.characters[std::size_t(c)].character;
      const std::int32_t joints = ch.skeleton.num_joints();
      const std::int64_t n = ch.mesh.num_vertices();
      const std::vector<float> truth = dense(ch.mesh.weights, joints);
      const std::filesystem::path f(td.description.characters[std::size_t(c)]);
      std::printf("| %s/%s |", f.parent_path().filename().c_str(), f.stem().c_str());
      for (int q = 0; q < 4; ++q) {
        const PreparedCharacter pc = prepare_character(turned(ch, q), DeltaMushParams{0, 0.5f});
        const std::vector<float> pred = dense(predict_skin_weights_any(*lm.model, lm.norm, pc, 4), joints);
        const WeightMetrics m = weight_metrics(pred, truth, joints);
        const double dom = dominant_accuracy(pred, truth, n, joints);
        l1_sum[q] += m.l1_mean;
        dom_sum[q] += dom;
        std::printf(" %.4f / %.3f |", m.l1_mean, dom);
      }
      std::printf("\n");
      ++count;
    }
    if (count == 0) throw InvalidArgument(std::string(argv[1]) + " has no " + part_name + " characters");
    std::printf("| **mean of %d** |", count);
    for (int q = 0; q < 4; ++q) std::printf(" %.4f / %.3f |", l1_sum[q] / count, dom_sum[q] / count);
    std::printf("\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "turned_weights: %s\n", e.what());
    return 2;
  }
  return 0;
}
