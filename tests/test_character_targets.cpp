// File targets (character/target_frames.hpp) and the reference-deformer
// interface: what gat deform writes (morph-target glTF, .pc2) and a .pc2 from
// another deformer (one cache per primitive) read back as per-frame target
// meshes, frame map and errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/file_targets.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/models/linear_skip.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/reference_deformer.hpp"
#include "gatcore/character/io/target_frames.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

std::string tmp(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "gatcore_target_tests";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// A synthetic nonlinear deformer: LBS pushed along its own normals by an
// amount that varies over the body (a function of the rest position: bands
// of bulges and dents that follow the skin as it moves).
std::vector<float> bulge(const Character& ch, const Pose& pose) {
  std::vector<float> p = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, pose));
  const std::vector<float> n = vertex_normals(p, ch.mesh.triangles);
  const std::vector<float>& r = ch.mesh.positions;
  for (std::size_t v = 0; v < p.size() / 3; ++v) {
    const float a = 0.02f * std::sin(6.0f * r[3 * v + 1]) * std::cos(4.0f * r[3 * v]);
    for (int c = 0; c < 3; ++c) p[3 * v + c] += a * n[3 * v + c];
  }
  return p;
}

}  // namespace

TEST_CASE("targets: gat deform's morph-target glTF and .pc2 read back as the baked frames", "[character][targets]") {
  ProceduralOptions o;
  o.seed = 3;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  const std::string src = tmp("humanoid.glb");
  save_gltf_character(procedural_character(o), src);
  const Character ch = load_gltf(src);
  const Clip clip =
      retarget(load_bvh(charfix::write_temp("swing_targets.bvh", procedural_swing_bvh(6))), ch.skeleton, mat4_identity());
  BakedFrames baked;
  baked.fps = clip.fps;
  for (const Pose& p : clip.frames) baked.positions.push_back(bulge(ch, p));
  const std::string glb = tmp("baked.glb"), pc2 = tmp("baked.pc2");
  save_gltf_morph_animation(src, ch, baked, glb);
  PointCache cache;
  cache.num_points = std::int32_t(ch.num_file_vertices());
  cache.start_frame = 2;
  for (const auto& p : baked.positions) cache.samples.push_back(file_vertex_positions(ch, p));
  write_point_cache(pc2, cache);

  const float tol = 1e-5f;
  SECTION("morph targets, with the source character or the baked file itself") {
    for (const Character& c : {ch, load_gltf(glb)}) {
      const TargetFrames t = read_target_frames(c, glb);
      REQUIRE(t.positions.size() == baked.positions.size());
      CHECK(t.start_frame == 0.0);
      for (std::size_t f = 0; f < t.positions.size(); ++f) CHECK(max_abs_diff(t.positions[f], baked.positions[f]) < tol);
    }
    CHECK_THROWS_WITH(read_morph_target_frames(ch, glb, "walk"), Contains("no animation named 'walk'"));
    CHECK_THROWS_WITH(read_morph_target_frames(ch, src), Contains(src) && Contains("no animation of morph weights"));
  }
  SECTION("one point cache: frames and the start frame") {
    const TargetFrames t = read_target_frames(ch, pc2);
    REQUIRE(t.positions.size() == baked.positions.size());
    CHECK(t.start_frame == 2.0);
    CHECK(t.frame_step == 1.0);
    for (std::size_t f = 0; f < t.positions.size(); ++f) CHECK(max_abs_diff(t.positions[f], baked.positions[f]) < tol);
  }
  SECTION("a single frame") {
    BakedFrames one{"deform", 30.0f, {baked.positions[2]}};
    save_gltf_morph_animation(src, ch, one, tmp("one.glb"));
    const TargetFrames t = read_target_frames(ch, tmp("one.glb"));
    REQUIRE(t.positions.size() == 1);
    CHECK(max_abs_diff(t.positions[0], baked.positions[2]) < tol);
  }
  SECTION("a cache of another character is rejected, naming both") {
    PointCache small = cache;
    small.num_points -= 1;
    for (auto& s : small.samples) s.resize(s.size() - 3);
    write_point_cache(tmp("small.pc2"), small);
    CHECK_THROWS_WITH(read_target_frames(ch, tmp("small.pc2")),
                      Contains("small.pc2") && Contains(std::to_string(ch.num_file_vertices()) + " file vertices"));
    CHECK_THROWS_WITH(read_target_frames(ch, tmp("x.obj")), Contains("unknown target file type"));
  }
}

TEST_CASE("targets: one .pc2 per primitive from another tool, in the file's order", "[character][targets]") {
  const std::string src = charfix::write_temp("two_primitives.glb", charfix::skinned_glb());
  const Character ch = load_gltf(src);
  REQUIRE(ch.primitives.size() == 2);
  // Another deformer: every vertex moved by a rotation about y plus a twist.
  std::vector<std::vector<float>> frames;
  for (int f = 0; f < 3; ++f) {
    std::vector<float> p = ch.mesh.positions;
    for (std::size_t v = 0; v < p.size() / 3; ++v) {
      const float a = 0.1f * float(f) * p[3 * v + 1], x = p[3 * v], z = p[3 * v + 2];
      p[3 * v] = std::cos(a) * x - std::sin(a) * z;
      p[3 * v + 2] = std::sin(a) * x + std::cos(a) * z;
    }
    frames.push_back(p);
  }
  std::vector<std::string> paths;
  for (std::size_t k = 0; k < ch.primitives.size(); ++k) {
    const SourcePrimitive& sp = ch.primitives[k];
    PointCache c;
    c.num_points = std::int32_t(sp.num_vertices);
    c.start_frame = 10;
    for (const auto& p : frames) {
      const std::vector<float> file = file_vertex_positions(ch, p);
      c.samples.emplace_back(file.begin() + 3 * sp.first_vertex, file.begin() + 3 * (sp.first_vertex + sp.num_vertices));
    }
    paths.push_back(tmp("prim" + std::to_string(k) + ".pc2"));
    write_point_cache(paths.back(), c);
  }
  const TargetFrames t = read_target_frames(ch, paths[0] + "," + paths[1]);
  REQUIRE(t.positions.size() == 3);
  CHECK(t.start_frame == 10.0);
  for (std::size_t f = 0; f < 3; ++f) CHECK(max_abs_diff(t.positions[f], frames[f]) < 1e-6f);
  // The wrong order does not line up with the primitives (unless they happen to be the same size).
  if (ch.primitives[0].num_vertices != ch.primitives[1].num_vertices)
    CHECK_THROWS_WITH(read_point_cache_frames(ch, {paths[1], paths[0]}), Contains("inside a primitive"));
  // Different sample counts.
  PointCache c = read_point_cache(paths[1]);
  c.samples.pop_back();
  write_point_cache(tmp("short.pc2"), c);
  CHECK_THROWS_WITH(read_point_cache_frames(ch, {paths[0], tmp("short.pc2")}), Contains("2 samples"));
}

TEST_CASE("reference deformers: Delta Mush and ARAP deform any pose, file targets only their frames",
          "[character][targets]") {
  const Character ch = charfix::tube_character(8, 8);
  const std::vector<float> lbs = ch.mesh.positions;
  const auto dm = delta_mush_reference(ch.mesh, {});
  CHECK(dm->kind() == ReferenceKind::delta_mush);
  CHECK(max_abs_diff(dm->deform(lbs, -1), delta_mush_apply(delta_mush_bind(ch.mesh), lbs)) == 0.0f);
  const auto ar = arap_reference(ch.mesh, {});
  CHECK(ar->kind() == ReferenceKind::arap);
  CHECK(max_abs_diff(ar->deform(lbs, -1), lbs) < 1e-5f);  // the rest pose is ARAP's minimum
  const auto files = file_reference({lbs, lbs}, "cache.pc2");
  CHECK(files->num_frames() == 2);
  CHECK(files->deform(lbs, 1) == lbs);
  CHECK_THROWS_WITH(files->deform(lbs, -1), Contains("cache.pc2") && Contains("no random poses"));
  CHECK_THROWS_WITH(files->deform(lbs, 2), Contains("frame 2 of 2"));
  CHECK(parse_reference_kind("arap", "x") == ReferenceKind::arap);
  CHECK_THROWS_WITH(parse_reference_kind("mush", "data.json"), Contains("data.json") && Contains("'mush'"));
}

namespace {

// A procedural humanoid written as .glb (file vertices, primitives, weld map as for any file).
std::string humanoid_file(std::uint32_t seed) {
  ProceduralOptions o;
  o.seed = seed;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  o.garments = false;
  const std::string p = tmp("train_humanoid_" + std::to_string(seed) + ".glb");
  save_gltf_character(procedural_character(o), p);
  return p;
}

double mean_norm(const Tensor& t) {
  double s = 0;
  for (std::int64_t i = 0; i < t.rows(); ++i)
    s += std::sqrt(double(t.at(i, 0)) * t.at(i, 0) + double(t.at(i, 1)) * t.at(i, 1) + double(t.at(i, 2)) * t.at(i, 2));
  return s / double(t.rows());
}

double mean_error(const Tensor& a, const Tensor& b) {
  double s = 0;
  for (std::int64_t i = 0; i < a.rows(); ++i) {
    double d = 0;
    for (int c = 0; c < 3; ++c) d += (double(a.at(i, c)) - b.at(i, c)) * (double(a.at(i, c)) - b.at(i, c));
    s += std::sqrt(d);
  }
  return s / double(a.rows());
}

}  // namespace

TEST_CASE("targets: a dataset of file targets (morph glTF and .pc2) trains a model that predicts them",
          "[character][targets][dataset]") {
  // Three characters: one baked as gat deform's morph-target glTF, two as
  // point caches written by "another deformer" (one starting at motion frame 2).
  const std::string bvh = charfix::write_temp("swing_dataset.bvh", procedural_swing_bvh(24));
  const Motion motion = load_bvh(bvh);
  std::vector<std::string> chars;
  std::vector<FileTargetSource> sources;
  for (std::uint32_t seed : {11u, 12u, 13u}) {
    const std::string src = humanoid_file(seed);
    const Character ch = load_gltf(src);
    const PreparedCharacter pc = prepare_character(ch);
    const Clip clip = retarget(motion, pc.character.skeleton, mat4_identity());
    const std::size_t first = seed == 13 ? 2 : 0;
    BakedFrames baked;
    for (std::size_t f = first; f < clip.frames.size(); ++f) baked.positions.push_back(bulge(pc.character, clip.frames[f]));
    FileTargetSource t;
    t.character = std::int32_t(chars.size());
    t.motion = bvh;
    if (seed == 11) {
      t.file = tmp("targets_11.glb");
      save_gltf_morph_animation(src, ch, baked, t.file);
    } else {
      PointCache cache;
      cache.num_points = std::int32_t(ch.num_file_vertices());
      cache.start_frame = float(first);
      for (const auto& p : baked.positions) cache.samples.push_back(file_vertex_positions(ch, p));
      t.file = tmp("targets_" + std::to_string(seed) + ".pc2");
      write_point_cache(t.file, cache);
    }
    chars.push_back(src);
    sources.push_back(t);
  }
  DatasetDescription settings;
  settings.random_poses = 0;
  settings.motion_stride = 2;
  settings.subsample = 0;
  settings.distortion_scales = {1, 4};
  settings.validation = 0.0f;
  settings.test = 0.0f;
  DatasetDescription d = describe_dataset(chars, {}, settings);
  d.split = Split{{0, 1}, {}, {2}};
  d.targets = sources;
  const std::string path = tmp("targets_dataset.json");
  save_dataset(path, d);
  const TrainingData td = load_training_data(path);
  REQUIRE(td.description.targets.size() == 3);
  CHECK(td.description.targets[2].file == sources[2].file);
  for (std::int32_t c = 0; c < 3; ++c)
    CHECK(td.characters[std::size_t(c)].reference->num_frames() == (c == 2 ? 22 : 24));

  // The samples' targets are the files' frames minus LBS, in the root frame.
  const PreparedCharacter& pc2 = td.characters[2];
  DenseGatsSample raw;
  densegats_full_sample(td, 2, pc2.target_poses[5], &raw, 5);
  const Clip clip2 = retarget(motion, pc2.character.skeleton, mat4_identity());
  const std::vector<float> want = apply_normalisation(pc2.normalisation, bulge(pc2.character, clip2.frames[7]));  // 2 + 5
  float worst = 0;
  for (std::int64_t v = 0; v < raw.lbs.rows(); ++v) {
    const Vec3 o = root_offset_to_world(raw, {raw.target.at(v, 0), raw.target.at(v, 1), raw.target.at(v, 2)});
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(raw.lbs.at(v, c) + o[std::size_t(c)] - want[3 * v + c]));
  }
  CHECK(worst < 1e-4f);

  // Every second frame per epoch, alternating phase; no random poses.
  const auto train0 = training_samples(td, models::Task::displacement, DatasetPart::train, 0);
  const auto train1 = training_samples(td, models::Task::displacement, DatasetPart::train, 1);
  CHECK(train0.size() == 24);
  CHECK(train1.size() == 24);
  CHECK(max_abs_diff(train0[0].target.to_vector(), train1[0].target.to_vector()) > 0.0f);

  // A small DenseGATs with the linear skip learns them: trained on the even
  // frames of two characters (epoch 0's phase every epoch), it predicts the
  // odd frames (epoch 1's) well below LBS (predicting zero). (The bulge
  // pattern is tied to each character's rest coordinates, so two training
  // characters say little about a third: not checked.)
  models::ModelConfig cfg = models::ModelConfig::defaults("densegats", td.feature_dim(models::Task::displacement));
  cfg.modules = 1;
  cfg.blocks = 2;
  cfg.heads = 2;
  cfg.head_dim = 8;
  cfg.transform = {16};
  cfg.head = {32};
  cfg.linear_skip = true;
  auto model = models::make_model(cfg, 3);
  const models::Normaliser norm = models::Normaliser::fit(train0, true);
  models::fit_linear_skip(*model, train0, norm);
  models::TrainOptions o = models::TrainOptions::defaults_for(cfg);
  o.sampling = models::Sampling::full;
  o.batch_size = 4;
  o.lr = 3e-3f;
  models::Trainer trainer(*model, o, norm);
  const auto test = training_samples(td, models::Task::displacement, DatasetPart::test, 0);
  REQUIRE(!test.empty());
  const auto errors = [&](const std::vector<models::Sample>& samples) {
    double lbs = 0, err = 0;
    for (const auto& s : samples) {
      lbs += mean_norm(s.target);
      err += mean_error(models::predict(*model, s, norm), s.target);
    }
    return std::pair{lbs / double(samples.size()), err / double(samples.size())};
  };
  const auto [lbs_odd, skip_odd] = errors(train1);
  for (int e = 0; e < 40; ++e) trainer.run_epoch(train0);
  const double odd = errors(train1).second;
  INFO("odd frames: LBS " << lbs_odd << ", linear skip " << skip_odd << ", trained " << odd);
  CHECK(odd < 0.5 * lbs_odd);
  CHECK(odd < skip_odd);
}

TEST_CASE("targets: bad file targets are refused naming the file and the problem", "[character][targets][dataset]") {
  const std::string src = humanoid_file(21);
  const Character ch = load_gltf(src);
  PreparedCharacter pc = prepare_character(ch);
  const std::string bvh = charfix::write_temp("swing_bad.bvh", procedural_swing_bvh(6));
  const Clip clip = retarget(load_bvh(bvh), pc.character.skeleton, mat4_identity());
  PointCache cache;
  cache.num_points = std::int32_t(ch.num_file_vertices());
  for (const Pose& p : clip.frames) cache.samples.push_back(file_vertex_positions(ch, bulge(pc.character, p)));
  write_point_cache(tmp("bad.pc2"), cache);
  FileTargetSource t{0, tmp("bad.pc2"), bvh, "", std::nullopt};
  const FileTargetSummary ok = attach_file_targets(pc, ch, t, "data.json");
  CHECK(ok.frames == 6);
  CHECK(ok.mean_to_lbs > 0.0);
  t.first_frame = 1.0;  // frames 1..6 of a 6-frame motion
  CHECK_THROWS_WITH(attach_file_targets(pc, ch, t, "data.json"),
                    Contains("data.json") && Contains("target frame 5") && Contains("frames 0..5"));
  t.first_frame.reset();
  // Another pose's targets (a Z-up export, say): far from LBS.
  PointCache turned = cache;
  for (auto& s : turned.samples)
    for (std::size_t v = 0; v < s.size() / 3; ++v) std::swap(s[3 * v + 1], s[3 * v + 2]);
  write_point_cache(tmp("turned.pc2"), turned);
  t.file = tmp("turned.pc2");
  CHECK_THROWS_WITH(attach_file_targets(pc, ch, t, "data.json"), Contains("turned.pc2") && Contains("up axis"));
  t.file = tmp("bad.pc2");
  t.motion = "clip:walk";
  CHECK_THROWS_WITH(attach_file_targets(pc, ch, t, "data.json"), Contains("none named 'walk'"));
}
