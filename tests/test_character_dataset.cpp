// Samples (DenseGATs / NeuroSkinning), the split by character, the oneTBB stream.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/motion.hpp"

using namespace gatcore::character;

TEST_CASE("split by character: disjoint, complete, deterministic per seed", "[character][dataset]") {
  const Split a = split_by_character(20, 0.1f, 0.2f, 7), b = split_by_character(20, 0.1f, 0.2f, 7),
              c = split_by_character(20, 0.1f, 0.2f, 8);
  CHECK(a.train == b.train);
  CHECK(a.test == b.test);
  CHECK((a.train != c.train || a.test != c.test));
  CHECK(a.validation.size() == 2);
  CHECK(a.test.size() == 4);
  CHECK(a.train.size() == 14);
  std::set<std::int32_t> all;
  for (const auto* v : {&a.train, &a.validation, &a.test}) all.insert(v->begin(), v->end());
  CHECK(all.size() == 20);
  const Split small = split_by_character(3, 0.1f, 0.1f, 1);
  CHECK(small.validation.size() == 1);
  CHECK(small.test.size() == 1);
  CHECK(small.train.size() == 1);
  CHECK_THROWS(split_by_character(5, 0.6f, 0.5f, 1));
}

TEST_CASE("DenseGATs samples: rest pose has no correction, a bent pose has one", "[character][dataset]") {
  ProceduralOptions o;
  o.seed = 2;
  const PreparedCharacter pc = prepare_character(procedural_character(o), DeltaMushParams{20, 0.5f});
  const std::int64_t n = pc.character.mesh.num_vertices();
  const std::int32_t J = pc.character.skeleton.num_joints();
  const DenseGatsSample rest = make_densegats_sample(pc, pc.rest, 0, 0);
  CHECK(rest.features.rows() == n);
  CHECK(rest.features.cols() == 6 + J);
  CHECK(rest.graph.num_nodes == n);
  float max_t = 0.0f;
  for (std::int64_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) max_t = std::max(max_t, std::abs(rest.target.at(i, c)));
  CHECK(max_t < 1e-5f);
  std::mt19937 rng(1);
  const Pose p = random_pose(pc.character.skeleton, pc.rest, uniform_limits(pc.character.skeleton, 0.8f), rng);
  const DenseGatsSample s = make_densegats_sample(pc, p, 100, 500);
  REQUIRE(s.vertices.size() == 500);
  CHECK(s.vertices.front() == 100);
  CHECK(s.graph.num_nodes == 500);
  s.features.check_finite("features");
  s.target.check_finite("target");
  double sum = 0.0;
  for (std::int64_t i = 0; i < 500; ++i)
    for (int c = 0; c < 3; ++c) sum += std::abs(s.target.at(i, c));
  CHECK(sum > 1e-3);
  CHECK_THROWS(make_densegats_sample(pc, p, n - 10, 500));
}

TEST_CASE("DenseGATs samples are in the root frame: root motion changes no feature and no target",
          "[character][dataset]") {
  ProceduralOptions o;
  o.seed = 3;
  const PreparedCharacter pc = prepare_character(procedural_character(o), DeltaMushParams{10, 0.5f}, std::vector{1, 4});
  const std::int32_t root = root_motion_joint(pc);
  REQUIRE(pc.character.skeleton.parents[std::size_t(root)] < 0);
  std::mt19937 rng(4);
  const Pose p = random_pose(pc.character.skeleton, pc.rest, uniform_limits(pc.character.skeleton, 0.7f), rng);
  // The same pose walked 2 units away and turned 70 degrees about the vertical.
  Pose moved = p;
  Transform& t = moved.local[std::size_t(root)];
  const Quat turn = quat_from_axis_angle({0.0f, 1.0f, 0.0f}, 1.2217f);
  t.rotation = quat_normalize(quat_mul(turn, t.rotation));
  t.translation = quat_rotate(turn, t.translation);
  t.translation[0] += 2.0f;
  t.translation[2] -= 1.0f;
  const DenseGatsSample a = make_densegats_sample(pc, p, 0, 0), b = make_densegats_sample(pc, moved, 0, 0);
  REQUIRE(a.features.rows() == b.features.rows());
  REQUIRE(a.distortion.cols() == 6);
  double df = 0.0, dt = 0.0, tmax = 0.0, dw = 0.0, lbs_moved = 0.0, dmax = 0.0;
  for (std::int64_t i = 0; i < a.features.rows(); ++i) {
    for (std::int64_t c = 0; c < a.distortion.cols(); ++c) {
      df = std::max(df, double(std::abs(a.distortion.at(i, c) - b.distortion.at(i, c))));
      dmax = std::max(dmax, double(std::abs(a.distortion.at(i, c))));
    }
    for (std::int64_t c = 0; c < a.features.cols(); ++c)
      df = std::max(df, double(std::abs(a.features.at(i, c) - b.features.at(i, c))));
    for (int c = 0; c < 3; ++c) {
      dt = std::max(dt, double(std::abs(a.target.at(i, c) - b.target.at(i, c))));
      tmax = std::max(tmax, double(std::abs(a.target.at(i, c))));
      lbs_moved = std::max(lbs_moved, double(std::abs(a.lbs.at(i, c) - b.lbs.at(i, c))));
    }
    // Back in the world: the moved sample's offset is the turned offset.
    const Vec3 wa = quat_rotate(turn, root_offset_to_world(a, {a.target.at(i, 0), a.target.at(i, 1), a.target.at(i, 2)}));
    const Vec3 wb = root_offset_to_world(b, {b.target.at(i, 0), b.target.at(i, 1), b.target.at(i, 2)});
    for (int c = 0; c < 3; ++c) dw = std::max(dw, double(std::abs(wa[std::size_t(c)] - wb[std::size_t(c)])));
  }
  INFO("feature diff " << df << ", target diff " << dt << " (max target " << tmax << "), world diff " << dw);
  CHECK(tmax > 1e-3);
  CHECK(dmax > 1e-3);
  CHECK(lbs_moved > 0.5);  // the world-frame LBS did move
  CHECK(df < 1e-3);
  CHECK(dt < 1e-3 * tmax + 1e-6);
  CHECK(dw < 1e-3 * tmax + 1e-6);
}

TEST_CASE("DenseGATs distortion columns: zero at rest and under rigid motion, not where joints bend",
          "[character][dataset]") {
  ProceduralOptions o;
  o.seed = 5;
  const PreparedCharacter pc = prepare_character(procedural_character(o), DeltaMushParams{10, 0.5f}, std::vector{2, 8});
  const std::int64_t n = pc.character.mesh.num_vertices();
  const auto max_abs = [](const gatcore::Tensor& t) {
    double m = 0.0;
    for (std::int64_t i = 0; i < t.rows(); ++i)
      for (std::int64_t c = 0; c < t.cols(); ++c) m = std::max(m, double(std::abs(t.at(i, c))));
    return m;
  };
  const DenseGatsSample rest = make_densegats_sample(pc, pc.rest, 0, 0, false);
  REQUIRE(rest.distortion.rows() == n);
  REQUIRE(rest.distortion.cols() == 6);
  CHECK(max_abs(rest.distortion) < 1e-5);
  // The whole character moved and turned rigidly (a non-root joint's
  // rotation would bend the skin; the root's does not).
  Pose rigid = pc.rest;
  const std::int32_t root = root_motion_joint(pc);
  Transform& t = rigid.local[std::size_t(root)];
  t.rotation = quat_normalize(quat_mul(quat_from_axis_angle({0.3f, 1.0f, 0.2f}, 0.9f), t.rotation));
  t.translation[1] += 0.7f;
  CHECK(max_abs(make_densegats_sample(pc, rigid, 0, 0, false).distortion) < 1e-5);
  std::mt19937 rng(2);
  const Pose bent = random_pose(pc.character.skeleton, pc.rest, uniform_limits(pc.character.skeleton, 0.8f), rng);
  const DenseGatsSample s = make_densegats_sample(pc, bent, 100, 400, false);
  REQUIRE(s.distortion.rows() == 400);
  s.distortion.check_finite("distortion");
  CHECK(max_abs(s.distortion) > 1e-3);
  // A window holds the whole-mesh sample's rows.
  const DenseGatsSample whole = make_densegats_sample(pc, bent, 0, 0, false);
  for (std::int64_t i = 0; i < 400; ++i)
    for (int c = 0; c < 6; ++c) CHECK(s.distortion.at(i, c) == whole.distortion.at(100 + i, c));
  // No scales: no columns, and the model's features are the paper's.
  const PreparedCharacter plain = prepare_character(procedural_character(o), DeltaMushParams{10, 0.5f});
  const DenseGatsSample p = make_densegats_sample(plain, bent, 0, 0, false);
  CHECK(!p.distortion.defined());
  CHECK(densegats_model_features(p.features, p).cols() == p.features.cols());
  CHECK(densegats_model_features(whole.features, whole).cols() == whole.features.cols() + 6);
}

TEST_CASE("NeuroSkinning samples hold normalised rest features and the weights", "[character][dataset]") {
  ProceduralOptions o;
  o.kind = ProceduralKind::creature;
  const PreparedCharacter pc = prepare_character(procedural_character(o));
  const NeuroSkinningSample s = make_neuroskinning_sample(pc);
  const std::int64_t n = pc.character.mesh.num_vertices();
  REQUIRE(s.weights.rows() == n);
  float lo = 1e9f, hi = -1e9f;
  for (std::int64_t i = 0; i < n; ++i) {
    float w = 0.0f;
    for (std::int64_t j = 0; j < s.weights.cols(); ++j) w += s.weights.at(i, j);
    CHECK(w == Approx(1.0f).margin(1e-5));
    lo = std::min(lo, s.features.at(i, 1));
    hi = std::max(hi, s.features.at(i, 1));
  }
  CHECK(hi - lo == Approx(1.0f).margin(1e-5));  // height normalised to 1
  const std::vector<std::int32_t> some = {5, 7, 9};
  CHECK(make_neuroskinning_sample(pc, some).features.rows() == 3);
}

TEST_CASE("the oneTBB sample stream delivers every task in order, same as direct calls", "[character][dataset]") {
  std::vector<PreparedCharacter> pcs;
  for (std::uint32_t seed : {0u, 1u}) {
    ProceduralOptions o;
    o.seed = seed;
    o.ring_segments = 8;
    pcs.push_back(prepare_character(procedural_character(o)));
  }
  std::vector<SampleTask> tasks;
  std::mt19937 rng(3);
  for (int i = 0; i < 10; ++i) {
    SampleTask t;
    t.character = i % 2;
    t.pose_index = i;
    t.pose = random_pose(pcs[t.character].character.skeleton, pcs[t.character].rest,
                         uniform_limits(pcs[t.character].character.skeleton, 0.5f), rng);
    t.first = 10 * i;
    t.count = 200;
    tasks.push_back(t);
  }
  std::vector<DenseGatsSample> got;
  stream_densegats_samples(pcs, tasks, [&](DenseGatsSample&& s) { got.push_back(std::move(s)); }, 3);
  REQUIRE(got.size() == tasks.size());
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    CHECK(got[i].pose == static_cast<std::int32_t>(i));
    CHECK(got[i].character == tasks[i].character);
    const DenseGatsSample ref = make_densegats_sample(pcs[tasks[i].character], tasks[i].pose, tasks[i].first, tasks[i].count);
    CHECK(got[i].features.to_vector() == ref.features.to_vector());
    CHECK(got[i].target.to_vector() == ref.target.to_vector());
  }
}

TEST_CASE("samples of a real character driven by a retargeted CMU walk", "[character][dataset][data]") {
  const auto dir = charfix::data_dir();
  const auto farmer = dir / "characters/quaternius/modular_men/Farmer.glb";
  const auto walk = dir / "motion/cmu/walk.bvh";
  if (dir.empty() || !std::filesystem::exists(farmer) || !std::filesystem::exists(walk)) {
    WARN("SKIPPED: data not found (" << farmer << ", " << walk << ")");
    return;
  }
  const PreparedCharacter pc = prepare_character(load_gltf(farmer.string()));
  const Clip clip = retarget(load_bvh(walk.string()), pc.character.skeleton, mat4_identity());
  const DenseGatsSample rest = make_densegats_sample(pc, pc.rest, 0, 1000);
  float max_t = 0.0f;
  for (std::int64_t i = 0; i < rest.target.rows(); ++i)
    for (int c = 0; c < 3; ++c) max_t = std::max(max_t, std::abs(rest.target.at(i, c)));
  CHECK(max_t < 1e-4f);
  const DenseGatsSample s = make_densegats_sample(pc, clip.frames[100], 0, 1000);
  s.features.check_finite("features");
  s.target.check_finite("target");
  CHECK(s.features.cols() == 6 + 49);
}

TEST_CASE("dataset descriptions round-trip and drive deterministic epochs", "[character][dataset]") {
  DatasetDescription settings;
  settings.random_poses = 3;
  settings.subsample = 300;
  settings.seed = 5;
  settings.validation = 0.25f;
  settings.test = 0.25f;
  settings.delta_mush = {15, 0.4f};
  const DatasetDescription d = describe_dataset(
      {"procedural:humanoid:0", "procedural:humanoid:1", "procedural:creature:2", "procedural:humanoid:3"}, {}, settings);
  CHECK(d.split.train.size() == 2);
  const auto path = (charfix::temp_dir() / "dataset.json").string();
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  save_dataset(path, d);
  const DatasetDescription e = load_dataset(path);
  CHECK(e.characters == d.characters);
  CHECK(e.split.train == d.split.train);
  CHECK(e.split.test == d.split.test);
  CHECK(e.delta_mush.iterations == 15);
  CHECK(e.delta_mush.step == 0.4f);
  CHECK(e.subsample == 300);
  std::vector<PreparedCharacter> pcs;
  for (const auto& c : e.characters) pcs.push_back(prepare_character(load_dataset_character(c), e.delta_mush));
  const auto t1 = dataset_tasks(e, pcs, {}, e.split.train, 0), t2 = dataset_tasks(e, pcs, {}, e.split.train, 0),
             t3 = dataset_tasks(e, pcs, {}, e.split.train, 1);
  REQUIRE(t1.size() == 6);
  for (std::size_t i = 0; i < t1.size(); ++i) {
    CHECK(t1[i].first == t2[i].first);
    CHECK(t1[i].pose.local[3].rotation == t2[i].pose.local[3].rotation);
    CHECK(t1[i].count == 300);
  }
  CHECK(t1[0].pose.local[3].rotation != t3[0].pose.local[3].rotation);
  std::size_t got = 0;
  stream_densegats_samples(pcs, t1, [&](DenseGatsSample&& s) { got += s.features.rows() == 300; });
  CHECK(got == 6);
  // Bad files name the file and the problem.
  const std::string bad = charfix::write_temp("bad_dataset.json", "{\"format\": \"gatcore-dataset\", \"version\": 1}");
  CHECK_THROWS_WITH(load_dataset(bad), Catch::Matchers::Contains("bad_dataset.json") && Catch::Matchers::Contains("characters"));
  const std::string garbage = charfix::write_temp("garbage_dataset.json", "not json");
  CHECK_THROWS_WITH(load_dataset(garbage), Catch::Matchers::Contains("garbage_dataset.json"));
  CHECK_THROWS_WITH(load_dataset_character("procedural:dragon:1"), Catch::Matchers::Contains("procedural:dragon:1"));
}

TEST_CASE("dataset files are validated like gat dataset build's options (the shared reproducers)", "[character][dataset]") {
  using Catch::Matchers::Contains;
  const std::string repro = std::string(GATCORE_SOURCE_DIR) + "/tests/fuzz/repro/";
  const std::pair<const char*, const char*> cases[] = {
      {"dataset_random_poses_1e20.json", "field \"random_poses\" = 1e+20 is out of range [0, 1e+06]"},
      {"cli_dataset_random_poses_2e9.json", "field \"random_poses\" = 2000000000 is out of range"},
      {"cli_motion_stride_0/dataset.json", "field \"motion_stride\" = 0 is out of range [1, 1e+06]"},
      {"cli_dataset_out_of_range/dataset.json", "field \"random_poses\" = -5 is out of range"},
  };
  for (const auto& [file, msg] : cases) {
    INFO(file);
    CHECK_THROWS_WITH(load_dataset(repro + file), Contains(repro + file) && Contains(msg));
  }
  // One field at a time, from a valid description.
  const DatasetDescription d = describe_dataset({"procedural:humanoid:0", "procedural:humanoid:1", "procedural:humanoid:2"}, {});
  const auto path = (charfix::temp_dir() / "ranges.json").string();
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  save_dataset(path, d);
  std::ifstream is(path);
  const nlohmann::json good = nlohmann::json::parse(is);
  auto rejects = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& msg) {
    nlohmann::json j = good;
    edit(j);
    const std::string p = charfix::write_temp("ranges_bad.json", j.dump());
    INFO(msg);
    CHECK_THROWS_WITH(load_dataset(p), Contains("ranges_bad.json") && Contains(msg));
  };
  rejects([](auto& j) { j["validation"] = 2.0; }, "field \"validation\" = 2.0 is out of range [0, 0.9]");
  rejects([](auto& j) { j["validation"] = 0.5; j["test"] = 0.5; }, "field \"validation + test\" = 1 is out of range");
  rejects([](auto& j) { j["split"]["train"].push_back(j["split"]["train"][0]); }, "is in split \"train\" and again in \"train\"");
  rejects([](auto& j) { j["split"]["test"].push_back(j["split"]["train"][0]); }, "and again in \"test\"");
  rejects([](auto& j) { j["split"]["test"].push_back(7); }, "split \"test\" names character 7 of 3");
  rejects([](auto& j) { j["split"]["test"].push_back(-1); }, "field \"split.test\" = -1 is out of range");
  rejects([](auto& j) { j["seed"] = -1; }, "field \"seed\" = -1");
  rejects([](auto& j) { j["seed"] = 1.5; }, "field \"seed\" = 1.5 is not a whole number");
  rejects([](auto& j) { j["subsample"] = -3; }, "field \"subsample\" = -3");
  rejects([](auto& j) { j["pose_angle"] = "wide"; }, "field \"pose_angle\" must be a number");
  rejects([](auto& j) { j["reference_deformer"]["iterations"] = 1e9; }, "field \"reference_deformer.iterations\"");
  rejects([](auto& j) { j["version"] = 1e300; }, "unsupported dataset version");
  CHECK_NOTHROW(load_dataset(path));
  // The library's own builder refuses the same values.
  DatasetDescription s;
  s.motion_stride = 0;
  CHECK_THROWS_WITH(describe_dataset({"procedural:humanoid:0"}, {}, s), Contains("field \"motion_stride\" = 0"));
  s = {};
  s.random_poses = 2000000000;
  CHECK_THROWS_WITH(describe_dataset({"procedural:humanoid:0"}, {}, s), Contains("field \"random_poses\""));
}
