// distortion_probe: how much of the DenseGATs target (Delta Mush - LBS) a
// *linear* map of per-vertex detail vectors explains on unseen characters
// (docs/RESULTS.md, "Why the paper's features were not enough").
//
//   distortion_probe DATASET.json MOTION.bvh [STRIDE]
//
// For each scale k of the dataset's distortion_scales (1,4,16 if it has
// none) it computes, per vertex, in the normalised root frame:
//   posed detail  p - S^k(p)       (the LBS mesh: the paper's input)
//   rest detail   A (r - S^k(r))   (the rest mesh, carried by LBS's blend A)
// and fits target ~ sum_k a_k posed_k + b_k rest_k by least squares on the
// training characters (8 random poses each; one scalar per vector, shared by
// x, y, z, so the fit is rotation-equivariant). It prints the mean
// per-vertex error (cm) of the fit next to predicting 0 (plain LBS) on the
// training poses, the test characters' random poses and every STRIDE-th
// frame (default 8) of MOTION on the test characters.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/io/bvh.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

struct Rows {
  std::vector<double> target, cm;       // [3 n], [n]
  std::vector<std::vector<double>> col;  // [features][3 n]
};

void add(Rows& rows, const PreparedCharacter& pc, const Pose& pose) {
  const DenseGatsSample s = make_densegats_sample(pc, pose, 0, 0, true);
  const std::int64_t n = pc.character.mesh.num_vertices();
  std::vector<float> p(3 * n);
  for (std::int64_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) p[3 * v + c] = s.features.at(v, c);
  const DetailHalves h = detail_halves(pc, skinning_matrices(pc.character.skeleton, pose), p, inverse(s.root_motion));
  const std::size_t S = h.posed.size();
  if (rows.col.empty()) rows.col.resize(2 * S);
  for (std::size_t k = 0; k < S; ++k) {
    rows.col[k].insert(rows.col[k].end(), h.posed[k].begin(), h.posed[k].end());
    rows.col[S + k].insert(rows.col[S + k].end(), h.rest[k].begin(), h.rest[k].end());
  }
  for (std::int64_t v = 0; v < n; ++v) {
    for (int c = 0; c < 3; ++c) rows.target.push_back(s.target.at(v, c));
    rows.cm.push_back(100.0 / pc.normalisation.scale);
  }
}

Eigen::VectorXd fit(const Rows& r, const std::vector<int>& use) {
  const auto m = static_cast<Eigen::Index>(use.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m);
  for (std::size_t i = 0; i < r.target.size(); ++i)
    for (Eigen::Index a = 0; a < m; ++a) {
      b[a] += r.col[use[a]][i] * r.target[i];
      for (Eigen::Index c = 0; c < m; ++c) A(a, c) += r.col[use[a]][i] * r.col[use[c]][i];
    }
  return A.ldlt().solve(b);
}

void report(const char* part, const Rows& r, const std::vector<int>& use, const Eigen::VectorXd& w) {
  double zero = 0, err = 0;
  const std::size_t n = r.cm.size();
  for (std::size_t v = 0; v < n; ++v) {
    double z2 = 0, e2 = 0;
    for (int c = 0; c < 3; ++c) {
      double y = 0;
      for (std::size_t k = 0; k < use.size(); ++k) y += w[Eigen::Index(k)] * r.col[use[k]][3 * v + c];
      z2 += r.target[3 * v + c] * r.target[3 * v + c];
      e2 += (r.target[3 * v + c] - y) * (r.target[3 * v + c] - y);
    }
    zero += std::sqrt(z2) * r.cm[v];
    err += std::sqrt(e2) * r.cm[v];
  }
  std::printf("  %-26s LBS %.4f cm   linear fit %.4f cm   (%+.1f %%)\n", part, zero / double(n), err / double(n),
              100.0 * (err / zero - 1.0));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: distortion_probe DATASET.json MOTION.bvh [STRIDE]\n");
    return 2;
  }
  try {
    TrainingData td = load_training_data(argv[1]);
    const Motion motion = load_bvh(argv[2]);
    const int stride = argc > 3 ? std::atoi(argv[3]) : 8;
    if (stride < 1) throw InvalidArgument(std::string("STRIDE must be >= 1, got '") + argv[3] + "'");
    std::vector<int> scales = td.description.distortion_scales;
    if (scales.empty()) {  // a dataset of the paper's features: probe the default scales
      scales = {1, 4, 16};
      for (PreparedCharacter& pc : td.characters) set_distortion_scales(pc, scales);
    }
    Rows train, test_random, test_motion;
    std::mt19937 rng(7);
    const auto random_poses = [&](Rows& rows, std::int32_t c) {
      const PreparedCharacter& pc = td.characters[std::size_t(c)];
      const auto limits = td.description.joint_limits ? td.description.joint_limits->limits_for(pc.character.skeleton)
                                                      : uniform_limits(pc.character.skeleton, td.description.pose_angle);
      for (int i = 0; i < 8; ++i) add(rows, pc, random_pose(pc.character.skeleton, pc.rest, limits, rng));
    };
    for (std::int32_t c : td.part(DatasetPart::train)) random_poses(train, c);
    for (std::int32_t c : td.part(DatasetPart::test)) {
      random_poses(test_random, c);
      const PreparedCharacter& pc = td.characters[std::size_t(c)];
      const Clip clip = retarget(motion, pc.character.skeleton, mat4_identity());
      for (std::size_t f = 0; f < clip.frames.size(); f += std::size_t(stride)) add(test_motion, pc, clip.frames[f]);
    }
    const int S = static_cast<int>(scales.size());
    std::vector<int> posed, rest, both;
    for (int k = 0; k < S; ++k) {
      posed.push_back(k);
      rest.push_back(S + k);
    }
    both = posed;
    both.insert(both.end(), rest.begin(), rest.end());
    std::printf("distortion_probe: %s, scales %s, %zu training / %zu test-pose / %zu test-motion vertices\n", argv[1],
                format_distortion_scales(scales).c_str(), train.cm.size(), test_random.cm.size(), test_motion.cm.size());
    for (const auto& [name, use] : {std::pair{"posed detail only (paper's input)", posed},
                                    std::pair{"rest detail only", rest}, std::pair{"posed + rest detail", both}}) {
      const Eigen::VectorXd w = fit(train, use);
      std::printf("%s, coefficients", name);
      for (Eigen::Index i = 0; i < w.size(); ++i) std::printf(" %.3f", w[i]);
      std::printf("\n");
      report("training characters", train, use, w);
      report("test characters, random", test_random, use, w);
      report("test characters, motion", test_motion, use, w);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "distortion_probe: %s\n", e.what());
    return 1;
  }
  return 0;
}
