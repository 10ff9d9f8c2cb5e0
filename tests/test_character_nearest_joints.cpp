// Skeleton-agnostic joint columns for the DenseGATs family (
// features/nearest_joints.hpp): the row function against a sort, the layout
// text, and a nearest-joint corrective checkpoint deforming skeletons whose
// names match none of its training bones — the same numbers whatever the
// joints are called, through gat deform's path and the runtime alike.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "character_fixtures.hpp"
#include "pose_fixtures.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/inference/corrective.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/runtime.hpp"

using namespace gatcore;
using namespace gatcore::character;

TEST_CASE("nearest_joint_distances: the K smallest, ascending; few joints repeat the farthest", "[nearest_joints]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> U(0.f, 2.f);
  for (int J : {1, 3, 4, 7, 31}) {
    for (int K : {1, 4, 8}) {
      std::vector<float> d(static_cast<std::size_t>(J));
      for (float& x : d) x = U(rng);
      if (J > 3) d[1] = d[2];  // ties
      std::vector<float> want = d;
      std::sort(want.begin(), want.end());
      while (int(want.size()) < K) want.push_back(want.back());
      want.resize(std::size_t(K));
      std::vector<float> got(static_cast<std::size_t>(K), -1.f);
      nearest_joint_distances(d.data(), J, K, got.data());
      INFO("J " << J << " K " << K);
      CHECK(got == want);
    }
  }
  // The tensor form keeps position and normal, then the K nearest.
  Tensor f = Tensor::empty(2, 6 + 5);
  for (std::int64_t i = 0; i < 2; ++i)
    for (std::int64_t c = 0; c < 11; ++c) f.at(i, c) = float(10 * i + (c < 6 ? c : 16 - c));
  const Tensor n = nearest_joint_columns(f, 3);
  REQUIRE(n.cols() == 9);
  for (std::int64_t i = 0; i < 2; ++i) {
    for (int c = 0; c < 6; ++c) CHECK(n.at(i, c) == f.at(i, c));
    CHECK(n.at(i, 6) == float(10 * i + 6));  // joint columns 10, 9, 8, 7, 6: nearest first
    CHECK(n.at(i, 7) == float(10 * i + 7));
    CHECK(n.at(i, 8) == float(10 * i + 8));
  }
  CHECK_THROWS_AS(nearest_joint_columns(f, 0), InvalidArgument);
  CHECK_THROWS_AS(nearest_joint_columns(Tensor::zeros(2, 6), 2), InvalidArgument);
}

TEST_CASE("joint column layouts round-trip through text; bad ones are named", "[nearest_joints]") {
  CHECK(parse_joint_columns("bones", "x") == 0);
  CHECK(parse_joint_columns("", "x") == 0);
  CHECK(parse_joint_columns("nearest:4", "x") == 4);
  CHECK(parse_joint_columns(format_joint_columns(7), "x") == 7);
  CHECK(format_joint_columns(0) == "bones");
  for (const char* bad : {"nearest:", "nearest:0", "nearest:33", "nearest:4x", "near:4", "4"})
    CHECK_THROWS_WITH(parse_joint_columns(bad, "--joint-columns"),
                      Catch::Matchers::Contains("--joint-columns") && Catch::Matchers::Contains(bad));
}

namespace {

using posefix::humanoid;

// An untrained DenseGATs checkpoint with nearest:K joint columns and
// distortion columns at scales 1,4, trained (by its metadata) on bones no
// test skeleton has: the plumbing is under test, not the quality.
std::string nearest_checkpoint(int K) {
  const std::int64_t in = 6 + K + 3 * 2;
  models::ModelConfig cfg = models::ModelConfig::defaults("densegats", in, 3);
  cfg.modules = 2, cfg.blocks = 2, cfg.head = {16};
  auto m = models::make_model(cfg, 5);
  models::Normaliser norm;
  norm.mean = Tensor::zeros(1, in);
  norm.inv_std = Tensor::full(1, in, 3.f);
  norm.target_scale = 4.f;
  const auto dir = std::filesystem::temp_directory_path() / "gatcore_nearest_joints_tests";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / ("nearest" + std::to_string(K) + ".gcm")).string();
  models::save_checkpoint(path, *m, norm,
                          {{"features", "densegats"},
                           {"skeleton", "training_bone_a,training_bone_b"},
                           {"distortion_scales", "1,4"},
                           {"joint_columns", format_joint_columns(K)}});
  return path;
}

}  // namespace

TEST_CASE("a nearest-joint corrective model deforms any skeleton, whatever its joints are called", "[nearest_joints]") {
  const std::string path = nearest_checkpoint(4);
  models::LoadedModel lm = models::load_checkpoint(path);
  REQUIRE(checkpoint_nearest_joints(lm.file, path) == 4);
  const std::vector<std::string> bones = character_model_bones(lm, path, models::Task::displacement);
  lm.model->fold_batch_norm();
  const Character a = humanoid(2);
  Character b = a;  // the same rig under other names (as another package would call them)
  for (std::size_t j = 0; j < b.skeleton.names.size(); ++j) b.skeleton.names[j] = "rig_joint_" + std::to_string(j * 7);
  const std::vector<int> scales = checkpoint_distortion_scales(lm.file, path);
  const CorrectiveBinding da = make_corrective_binding(a, bones, {}, scales, 4);
  const CorrectiveBinding db = make_corrective_binding(b, bones, {}, scales, 4);
  // The paper's layout refuses these skeletons (no joint has a training bone's name).
  CHECK_THROWS_AS(make_corrective_binding(a, bones, {}, scales, 0), InvalidArgument);

  runtime::Deformer rt = runtime::Deformer::load(path);
  rt.bind(b.mesh, b.skeleton);
  CHECK(rt.mapped_joints() == b.skeleton.num_joints());
  const std::size_t n3 = std::size_t(3 * rt.num_vertices());
  std::vector<float> out(n3);
  for (int f = 0; f < 3; ++f) {
    const Pose pose = posefix::test_pose(a.skeleton, f);
    const CorrectedFrame fa = deform_frame(da, *lm.model, lm.norm, pose);
    const CorrectedFrame fb = deform_frame(db, *lm.model, lm.norm, pose);
    CHECK(fa.corrected == fb.corrected);  // names change nothing
    float corr = 0;
    for (std::size_t i = 0; i < fa.corrected.size(); ++i) corr = std::max(corr, std::abs(fa.corrected[i] - fa.lbs[i]));
    CHECK(corr > 0.f);  // a real correction was compared
    // The runtime computes the same columns (one row function).
    rt.deform(posefix::globals_of(b.skeleton, pose), out);
    CHECK(out == fb.corrected);
  }

  // The same character in centimetres, 13 m from the origin (an FBX from
  // Mixamo or Unreal beside a glTF in metres): the columns and the offsets
  // live in the character's normalised frame, so the corrected mesh is the
  // metres one in the new units, in gat deform and in the runtime.
  {
    const Character cm = posefix::moved_and_scaled(a, 100.f, {250.f, -40.f, 1300.f});
    const CorrectiveBinding dm = make_corrective_binding(cm, bones, {}, scales, 4);
    runtime::Deformer rm = runtime::Deformer::load(path);
    rm.bind(cm.mesh, cm.skeleton);
    for (int f = 0; f < 3; ++f) {
      const Pose pose = posefix::test_pose(a.skeleton, f);
      const CorrectedFrame fa = deform_frame(da, *lm.model, lm.norm, pose);
      const CorrectedFrame fm = deform_frame(dm, *lm.model, lm.norm, posefix::test_pose(cm.skeleton, f));
      REQUIRE(fm.corrected.size() == fa.corrected.size());
      const float t[3] = {250.f, -40.f, 1300.f};
      double worst = 0, corr = 0;
      for (std::size_t i = 0; i < fa.corrected.size(); ++i) {
        worst = std::max(worst, std::abs(double(fm.corrected[i]) - (100.0 * fa.corrected[i] + t[i % 3])));
        corr = std::max(corr, 100.0 * std::abs(fa.corrected[i] - fa.lbs[i]));
      }
      INFO("frame " << f << ": largest difference " << worst << " cm, largest correction " << corr << " cm");
      CHECK(worst < 2e-3);  // a float at 1300 keeps 1.2e-4
      CHECK(corr > 100 * worst);
      rm.deform(posefix::globals_of(cm.skeleton, posefix::test_pose(cm.skeleton, f)), out);
      CHECK(out == fm.corrected);
    }
  }

  // Another skeleton altogether (two joints: fewer than K, the farthest
  // repeats) binds and deforms.
  const Character c = charfix::tube_character(8, 8, 2.0f, 0.25f, 0.3f);
  REQUIRE(c.skeleton.num_joints() < 4);
  const CorrectiveBinding dc = make_corrective_binding(c, bones, {}, scales, 4);
  const CorrectedFrame fc = deform_frame(dc, *lm.model, lm.norm, posefix::test_pose(c.skeleton, 1));
  for (float x : fc.corrected) REQUIRE(std::isfinite(x));
}
