// Predictions back into files: save_gltf_character, predicted skin weights
// (predict_skin_weights + save_gltf_with_weights), DenseGATs corrections baked
// as glTF morph targets (save_gltf_morph_animation) and point caches.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/inference/corrective.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

std::string tmp(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "gatcore_export_tests";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A small procedural humanoid written as .glb and read back (joint nodes,
// primitives, weld map as for any file).
std::string humanoid_glb(std::uint32_t seed) {
  ProceduralOptions o;
  o.seed = seed;
  o.ring_segments = 8;
  o.rings_per_bone = 3;
  const std::string p = tmp("humanoid_" + std::to_string(seed) + ".glb");
  save_gltf_character(procedural_character(o), p);
  return p;
}

std::vector<std::string> bone_names(const Skeleton& s, const std::vector<std::string>& extra = {}) {
  std::vector<std::string> b;
  for (const auto& n : s.names) b.push_back(normalise_bone_name(n));
  b.insert(b.end(), extra.begin(), extra.end());
  return b;
}

// Small models of the two tasks, fresh weights (the plumbing, not the
// quality, is under test), with a normaliser fitted on one sample.
std::unique_ptr<models::Model> small_model(const std::string& name, std::int64_t bones) {
  models::ModelConfig cfg = models::ModelConfig::defaults(name, 6 + bones, name == "densegats" ? 3 : bones);
  if (name == "densegats") cfg.modules = 1, cfg.blocks = 2, cfg.head = {32};
  else cfg.stage1 = {16}, cfg.gc_dims = {8, 8, 8}, cfg.global_mlp = {32}, cfg.classifier = {32}, cfg.gc_pool = {4, 6, 8};
  return models::make_model(cfg, 3);
}

models::Normaliser fit_norm(const Tensor& features, bool displacement) {
  models::Sample s;
  s.features = features;
  s.target = Tensor::zeros(features.rows(), 3);
  for (std::int64_t i = 0; i < s.target.rows(); ++i) s.target.at(i, 0) = 0.01f * float(i % 7);
  return models::Normaliser::fit({s}, displacement);
}

std::string slurp(const std::string& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

tinygltf::Model read_gltf(const std::string& p) {
  tinygltf::Model m;
  tinygltf::TinyGLTF g;
  std::string err, warn;
  REQUIRE(g.LoadBinaryFromFile(&m, &err, &warn, p));
  return m;
}

// Accessor `a` as floats (tightly packed float accessors, as gatcore writes them).
std::vector<float> floats(const tinygltf::Model& m, int a) {
  const auto& acc = m.accessors.at(std::size_t(a));
  const auto& v = m.bufferViews.at(std::size_t(acc.bufferView));
  REQUIRE(acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT);
  const std::size_t n = acc.count * std::size_t(tinygltf::GetNumComponentsInType(std::uint32_t(acc.type)));
  REQUIRE((v.byteStride == 0 || v.byteStride == n / acc.count * 4));
  std::vector<float> out(n);
  std::memcpy(out.data(), m.buffers[std::size_t(v.buffer)].data.data() + v.byteOffset + acc.byteOffset, 4 * n);
  return out;
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float d = 0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

}  // namespace

TEST_CASE("save_gltf_character writes a character load_gltf reads back", "[character][export]") {
  ProceduralOptions o;
  o.seed = 2;
  o.kind = ProceduralKind::creature;
  const Character ch = procedural_character(o);
  const std::string p = tmp("creature.glb");
  save_gltf_character(ch, p);
  const Character back = load_gltf(p);
  // The importer orders joints depth first and welds coincident vertices:
  // compare through joint names and the weld map.
  REQUIRE(back.skeleton.num_joints() == ch.skeleton.num_joints());
  std::vector<std::int32_t> to_back(ch.skeleton.names.size());
  for (std::size_t j = 0; j < to_back.size(); ++j) {
    to_back[j] = back.skeleton.find(ch.skeleton.names[j]);
    REQUIRE(to_back[j] >= 0);
    const std::int32_t p = ch.skeleton.parents[j];
    CHECK(back.skeleton.parents[std::size_t(to_back[j])] == (p < 0 ? -1 : to_back[std::size_t(p)]));
  }
  REQUIRE(back.num_file_vertices() == ch.mesh.num_vertices());
  CHECK(back.mesh.num_triangles() == ch.mesh.num_triangles());
  const std::vector<float> dense = back.mesh.weights.dense(back.skeleton.num_joints());
  const auto J = std::size_t(back.skeleton.num_joints());
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    const auto w = std::size_t(back.welded_from_file[std::size_t(v)]);
    for (int c = 0; c < 3; ++c) CHECK(back.mesh.positions[3 * w + c] == ch.mesh.positions[3 * v + c]);
    // Coincident vertices are averaged on import; the generator gives them equal weights.
    for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k)
      CHECK(dense[w * J + std::size_t(to_back[std::size_t(ch.mesh.weights.joint[k])])] ==
            Approx(ch.mesh.weights.weight[k]).margin(1e-6));
  }
  // The bind pose of the file reproduces the mesh (inverse bind matrices and nodes agree).
  CHECK(max_abs_diff(linear_blend_skinning(back.mesh, skinning_matrices(back.skeleton, rest_pose(back.skeleton))),
                     back.mesh.positions) < 1e-4f);
  CHECK(!std::filesystem::exists(p + ".tmp"));
  CHECK_THROWS_WITH(save_gltf_character(ch, tmp("no_such_dir/x.glb")), Contains("x.glb"));
  CHECK(!std::filesystem::exists(tmp("no_such_dir/x.glb.tmp")));
}

TEST_CASE("predicted skin weights go back into the file and re-import", "[character][export][weights]") {
  // The tube fixture: a UV seam (welded vertices), two primitives, a weightless
  // helper joint, an animation. The model also knows a bone the tube lacks.
  const std::string src = charfix::write_temp("export_tube.glb", charfix::skinned_glb());
  const Character ch = load_gltf(src);
  REQUIRE(ch.num_file_vertices() > ch.mesh.num_vertices());  // the seam was welded
  const std::vector<std::string> bones = bone_names(ch.skeleton, {"tail"});
  const auto B = std::int64_t(bones.size());
  auto model = small_model("neuroskinning", B);
  const PreparedCharacter pc = prepare_character(ch);
  const BoneMapping map = map_bones(ch.skeleton, bones, {}, "tube");
  CHECK(map.num_mapped() == ch.skeleton.num_joints());
  CHECK(map.bone_to_joint.back() == -1);
  const models::Normaliser norm = fit_norm(features_in_bone_order(make_neuroskinning_sample(pc).features, map), false);

  for (int K : {2, 6}) {
    INFO("max influences " << K);
    const WeightPrediction p = predict_skin_weights(*model, norm, bones, ch, K);
    REQUIRE(p.weights.num_vertices() == ch.mesh.num_vertices());
    for (std::int64_t v = 0; v < p.weights.num_vertices(); ++v) {
      const std::int64_t n = p.weights.ptr[v + 1] - p.weights.ptr[v];
      CHECK((n >= 1 && n <= std::min<std::int64_t>(K, ch.skeleton.num_joints())));
      double sum = 0;
      for (std::int64_t k = p.weights.ptr[v]; k < p.weights.ptr[v + 1]; ++k) sum += p.weights.weight[k];
      CHECK(sum == Approx(1.0).margin(1e-5));
    }
    const std::string out = tmp("tube_weights_" + std::to_string(K) + ".glb");
    save_gltf_with_weights(src, ch, p.weights, out, K);
    CHECK(!std::filesystem::exists(out + ".tmp"));
    const Character back = load_gltf(out);
    CHECK(back.num_file_vertices() == ch.num_file_vertices());
    CHECK(back.welded_from_file == ch.welded_from_file);
    CHECK(back.mesh.positions == ch.mesh.positions);
    CHECK(back.mesh.triangles == ch.mesh.triangles);
    CHECK(back.skeleton.names == ch.skeleton.names);
    CHECK(back.clips.size() == ch.clips.size());
    CHECK(back.mesh.weights.joint == p.weights.joint);
    REQUIRE(back.mesh.weights.weight.size() == p.weights.weight.size());
    for (std::size_t k = 0; k < p.weights.weight.size(); ++k)
      CHECK(back.mesh.weights.weight[k] == Approx(p.weights.weight[k]).margin(1e-6));
    // More than 4 influences: a second set of attributes.
    const tinygltf::Model m = read_gltf(out);
    const auto& attrs = m.meshes.at(0).primitives.at(0).attributes;
    CHECK(attrs.count("JOINTS_1") == (K > 4 ? 1u : 0u));
    CHECK(attrs.count("WEIGHTS_1") == (K > 4 ? 1u : 0u));
    CHECK(m.animations.size() == read_gltf(src).animations.size());
    CHECK(m.nodes.size() == read_gltf(src).nodes.size());
  }
}

TEST_CASE("checkpoints and characters that do not fit predict-weights / deform", "[character][export][errors]") {
  const std::string src = humanoid_glb(5);
  const Character ch = load_gltf(src);
  const std::vector<std::string> bones = bone_names(ch.skeleton);
  const auto B = std::int64_t(bones.size());
  const std::string joined = [&] {
    std::string s;
    for (const auto& b : bones) s += (s.empty() ? "" : ",") + b;
    return s;
  }();
  models::Normaliser norm;
  norm.mean = Tensor::zeros(1, 6 + B);
  norm.inv_std = Tensor::full(1, 6 + B, 1.f);
  const std::string dg = tmp("dg.gcm"), ns = tmp("ns.gcm"), tube = tmp("tube.gcm"), old = tmp("old_ns.gcm");
  models::save_checkpoint(dg, *small_model("densegats", B), norm, nullptr, {{"features", "densegats"}, {"skeleton", joined}});
  models::save_checkpoint(ns, *small_model("neuroskinning", B), norm, nullptr,
                          {{"features", "neuroskinning"}, {"skeleton", joined}});
  models::save_checkpoint(tube, *small_model("neuroskinning", B), norm, nullptr, {{"skeleton", joined}});
  // Written before the "features" key existed: a dataset model is recognised by its data_path.
  models::save_checkpoint(old, *small_model("neuroskinning", B), norm, nullptr,
                          {{"data_path", "/somewhere/data.json"}, {"skeleton", joined}});

  CHECK_THROWS_WITH(character_model_bones(models::load_checkpoint(dg), dg, models::Task::weights),
                    Contains("dg.gcm") && Contains("densegats model for displacement"));
  CHECK_THROWS_WITH(character_model_bones(models::load_checkpoint(ns), ns, models::Task::displacement),
                    Contains("ns.gcm") && Contains("not one for displacement"));
  CHECK_THROWS_WITH(character_model_bones(models::load_checkpoint(tube), tube, models::Task::weights),
                    Contains("embedded tube"));
  CHECK(character_model_bones(models::load_checkpoint(old), old, models::Task::weights) == bones);
  CHECK(character_model_bones(models::load_checkpoint(ns), ns, models::Task::weights) == bones);
  CHECK(character_model_bones(models::load_checkpoint(dg), dg, models::Task::displacement) == bones);
  CHECK_THROWS_WITH(models::load_checkpoint(tmp("missing.gcm")), Contains("missing.gcm"));

  // Joints that match no bone, and two joints on one bone.
  Skeleton odd = ch.skeleton;
  for (auto& n : odd.names) n = "xx_" + n + "_yy";
  CHECK_THROWS_WITH(map_bones(odd, bones, {}, "odd.glb"), Contains("odd.glb") && Contains("none of its 19 joints"));
  BoneAliases alias;
  alias.pairs = {{normalise_bone_name(odd.names[0]), bones[0]}};
  CHECK(map_bones(odd, bones, alias, "odd.glb").num_mapped() == 1);
  Skeleton twice = ch.skeleton;
  twice.names[1] = "hips";
  CHECK_THROWS_WITH(map_bones(twice, bones, {}, "twice.glb"), Contains("both map to bone 'hips'"));

  // The wrong model for the task.
  auto dgm = small_model("densegats", B);
  CHECK_THROWS_WITH(predict_skin_weights(*dgm, norm, bones, ch), Contains("not skin weights"));
  auto nsm = small_model("neuroskinning", B);
  const CorrectiveBinding d = make_corrective_binding(ch, bones);
  CHECK_THROWS_WITH(deform_frame(d, *nsm, norm, d.prepared.rest), Contains("not displacements"));
}

TEST_CASE("deform: morph target f is LBS + the predicted correction of frame f, the .pc2 holds the same",
          "[character][export][deform]") {
  const std::string src = humanoid_glb(7);
  const Character ch = load_gltf(src);
  const std::vector<std::string> bones = bone_names(ch.skeleton, {"tail"});
  auto model = small_model("densegats", std::int64_t(bones.size()));
  model->fold_batch_norm();
  const CorrectiveBinding d = make_corrective_binding(ch, bones);
  const Motion motion = load_bvh(charfix::write_temp("swing.bvh", procedural_swing_bvh()));
  const Clip clip = retarget(motion, d.prepared.character.skeleton, mat4_identity());
  REQUIRE(clip.frames.size() >= 4);
  const models::Normaliser norm =
      fit_norm(features_in_bone_order(make_densegats_sample(d.prepared, clip.frames[0], 0, 0).features, d.mapping), true);

  BakedFrames baked;
  baked.fps = clip.fps;
  const float height = 1.0f / d.prepared.normalisation.scale;
  for (int f = 0; f < 4; ++f) {
    const Pose& pose = clip.frames[std::size_t(f)];
    const CorrectedFrame cf = deform_frame(d, *model, norm, pose);
    // LBS, computed independently on the file's own (bind-space) character.
    CHECK(max_abs_diff(cf.lbs, linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, pose))) < 1e-5f * height);
    // The correction is the model's prediction, back in character units.
    DenseGatsSample ds = make_densegats_sample(d.prepared, pose, 0, 0);
    models::Sample s;
    s.features = features_in_bone_order(ds.features, d.mapping);
    s.graph = share(std::move(ds.graph));
    const Tensor y = models::predict(*model, s, norm);
    float corr = 0;
    for (std::int64_t v = 0; v < y.rows(); ++v)
      for (int c = 0; c < 3; ++c) {
        const float want = y.at(v, c) * height;
        CHECK(cf.corrected[3 * v + c] - cf.lbs[3 * v + c] == Approx(want).margin(1e-5f * height));
        corr = std::max(corr, std::abs(want));
      }
    CHECK(corr > 0.0f);
    baked.positions.push_back(cf.corrected);
  }

  const std::string out = tmp("deformed.glb"), pc2 = tmp("deformed.pc2");
  save_gltf_morph_animation(src, ch, baked, out);
  PointCache cache;
  cache.num_points = std::int32_t(ch.num_file_vertices());
  cache.start_frame = 0;
  for (const auto& p : baked.positions) cache.samples.push_back(file_vertex_positions(ch, p));
  write_point_cache(pc2, cache);

  // The morph targets: base + target f = the corrected positions of frame f.
  const tinygltf::Model m = read_gltf(out);
  const auto& prim = m.meshes.at(0).primitives.at(0);
  REQUIRE(prim.targets.size() == 4);
  const std::vector<float> base = floats(m, prim.attributes.at("POSITION"));
  for (int f = 0; f < 4; ++f) {
    std::vector<float> shown = floats(m, prim.targets[std::size_t(f)].at("POSITION"));
    for (std::size_t i = 0; i < shown.size(); ++i) shown[i] += base[i];
    CHECK(max_abs_diff(shown, file_vertex_positions(ch, baked.positions[std::size_t(f)])) < 1e-5f * height);
  }
  // The animation steps the weights: at key f only target f is on.
  REQUIRE(m.animations.size() == 1);
  const auto& anim = m.animations[0];
  CHECK(anim.name == "deform");
  bool found = false;
  for (const auto& c : anim.channels) {
    if (c.target_path != "weights") continue;
    found = true;
    const auto& smp = anim.samplers.at(std::size_t(c.sampler));
    CHECK(smp.interpolation == "STEP");
    const std::vector<float> t = floats(m, smp.input), w = floats(m, smp.output);
    REQUIRE(t.size() == 5);
    REQUIRE(w.size() == 5 * 4);
    for (int k = 0; k < 5; ++k) {
      CHECK(t[std::size_t(k)] == Approx(k / clip.fps));
      for (int f = 0; f < 4; ++f) CHECK(w[std::size_t(4 * k + f)] == (f == std::min(k, 3) ? 1.f : 0.f));
    }
  }
  CHECK(found);
  // Re-import: still the same skinned character, and its "deform" clip holds
  // the joints at the bind pose, so skinning leaves the base mesh in place.
  const Character back = load_gltf(out);
  CHECK(back.mesh.positions == ch.mesh.positions);
  CHECK(back.mesh.weights.joint == ch.mesh.weights.joint);
  REQUIRE(back.clips.size() == 1);
  CHECK(max_abs_diff(linear_blend_skinning(back.mesh, skinning_matrices(back.skeleton, back.clips[0].frames.at(2))),
                     back.mesh.positions) < 1e-5f * height);
  // Another importer reads it too, and the JSON flavour holds the same.
  CHECK(load_assimp_character(out).num_file_vertices() == ch.num_file_vertices());
  const std::string json = tmp("deformed.gltf");
  save_gltf_morph_animation(src, ch, baked, json);
  const Character back_json = load_gltf(json);
  CHECK(back_json.mesh.positions == back.mesh.positions);
  REQUIRE(back_json.clips.size() == 1);
  CHECK(back_json.clips[0].frames.size() == back.clips[0].frames.size());

  // The point cache: header and positions.
  const std::string bytes = slurp(pc2);
  REQUIRE(bytes.size() == 32 + 4 * 12 * std::size_t(ch.num_file_vertices()));
  CHECK(std::memcmp(bytes.data(), "POINTCACHE2\0", 12) == 0);
  std::int32_t hdr[2];
  std::memcpy(hdr, bytes.data() + 12, 8);
  CHECK(hdr[0] == 1);
  CHECK(hdr[1] == ch.num_file_vertices());
  const PointCache rc = read_point_cache(pc2);
  CHECK(rc.sample_rate == 1.0f);
  REQUIRE(rc.samples.size() == 4);
  for (int f = 0; f < 4; ++f) CHECK(rc.samples[std::size_t(f)] == cache.samples[std::size_t(f)]);
}

TEST_CASE("deform bakes joints given by matrices as TRS (glTF animates only TRS nodes)", "[character][export][deform]") {
  tinygltf::Model m = read_gltf(humanoid_glb(5));
  int changed = 0;
  for (auto& n : m.nodes) {
    if (n.name != "UpperArm.L") continue;
    ++changed;
    Transform t;
    for (int c = 0; c < 3; ++c) t.translation[std::size_t(c)] = float(n.translation[std::size_t(c)]);
    for (int c = 0; c < 4; ++c) t.rotation[std::size_t(c)] = float(n.rotation[std::size_t(c)]);
    const Mat4 mat = to_matrix(t);
    n.matrix.assign(mat.begin(), mat.end());
    n.translation.clear(), n.rotation.clear(), n.scale.clear();
  }
  REQUIRE(changed == 1);
  const std::string src = tmp("humanoid_matrix.glb");
  tinygltf::TinyGLTF g;
  REQUIRE(g.WriteGltfSceneToFile(&m, src, true, true, false, true));
  const Character ch = load_gltf(src);
  BakedFrames one;
  one.positions = {ch.mesh.positions};
  const std::string out = tmp("humanoid_matrix_baked.glb");
  save_gltf_morph_animation(src, ch, one, out);
  const tinygltf::Model b = read_gltf(out);
  for (const auto& c : b.animations.at(0).channels)
    CHECK(b.nodes.at(std::size_t(c.target_node)).matrix.empty());
  const Character back = load_gltf(out);
  CHECK(max_abs_diff(linear_blend_skinning(back.mesh, skinning_matrices(back.skeleton, rest_pose(back.skeleton))),
                     linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, rest_pose(ch.skeleton)))) < 1e-5f);
}

TEST_CASE("bake and point cache errors leave no file behind", "[character][export][errors]") {
  const std::string src = humanoid_glb(5);
  const Character ch = load_gltf(src);
  const std::string out = tmp("never.glb");
  std::filesystem::remove(out);
  BakedFrames none;
  CHECK_THROWS_WITH(save_gltf_morph_animation(src, ch, none, out), Contains("never.glb") && Contains("no frames"));
  BakedFrames bad;
  bad.positions.push_back(ch.mesh.positions);
  bad.positions[0][5] = std::nanf("");
  CHECK_THROWS_WITH(save_gltf_morph_animation(src, ch, bad, out), Contains("frame 0 vertex 1 is not finite"));
  bad.positions[0].resize(6);
  CHECK_THROWS_WITH(save_gltf_morph_animation(src, ch, bad, out), Contains("2 positions for"));
  CHECK_THROWS_WITH(save_gltf_morph_animation(tmp("missing.glb"), ch, BakedFrames{"d", 30.f, {ch.mesh.positions}}, out),
                    Contains("missing.glb"));
  CHECK(!std::filesystem::exists(out));
  CHECK_THROWS_WITH(save_gltf_morph_animation(src, ch, BakedFrames{"d", 30.f, {ch.mesh.positions}}, tmp("nodir/o.glb")),
                    Contains("o.glb"));
  CHECK(!std::filesystem::exists(tmp("nodir/o.glb.tmp")));

  PointCache pc;
  CHECK_THROWS_WITH(write_point_cache(tmp("e.pc2"), pc), Contains("e.pc2"));
  pc.num_points = 2;
  pc.samples = {{0, 0, 0, 1, 1}};
  CHECK_THROWS_WITH(write_point_cache(tmp("e.pc2"), pc), Contains("sample 0 has 5 floats for 2 points"));
  CHECK(!std::filesystem::exists(tmp("e.pc2")));
  charfix::write_temp("bad.pc2", "POINTCACHE2");
  CHECK_THROWS_WITH(read_point_cache(charfix::write_temp("bad.pc2", "POINTCACHE2")), Contains("bad.pc2") && Contains("truncated"));
  CHECK_THROWS_WITH(read_point_cache(charfix::write_temp("bad2.pc2", std::string(40, 'x'))), Contains("no POINTCACHE2"));
  pc.samples = {{0, 0, 0, 1, 1, 1}};
  write_point_cache(tmp("ok.pc2"), pc);
  std::string cut = slurp(tmp("ok.pc2"));
  cut.pop_back();
  CHECK_THROWS_WITH(read_point_cache(charfix::write_temp("cut.pc2", cut)), Contains("truncated or corrupted"));
  // Counts from the file are checked against its size before
  // anything is allocated, without wrap-around.
  const std::string repro = std::string(GATCORE_SOURCE_DIR) + "/tests/fuzz/repro/";
  CHECK_THROWS_WITH(read_point_cache(repro + "pc2_zero_points_1e9_samples.pc2"),
                    Contains("pc2_zero_points_1e9_samples.pc2") && Contains("needs at least one of each"));
  CHECK_THROWS_WITH(read_point_cache(repro + "pc2_zero_points_null_memcpy.pc2"), Contains("needs at least one of each"));
  CHECK_THROWS_WITH(read_point_cache(repro + "pc2_size_check_wraps.pc2"),
                    Contains("pc2_size_check_wraps.pc2") && Contains("truncated or corrupted"));
  std::string nan = slurp(tmp("ok.pc2"));
  const float q = std::nanf("");
  std::memcpy(&nan[32 + 4], &q, 4);
  CHECK_THROWS_WITH(read_point_cache(charfix::write_temp("nan.pc2", nan)), Contains("sample 0 point 0 holds a non-finite value"));
}

TEST_CASE("deform on Vulkan matches the CPU", "[character][export][deform][vulkan]") {
  if (!vkt::ready()) return;
  const std::string src = humanoid_glb(7);
  const Character ch = load_gltf(src);
  const std::vector<std::string> bones = bone_names(ch.skeleton);
  auto cpu = small_model("densegats", std::int64_t(bones.size()));
  auto vk = small_model("densegats", std::int64_t(bones.size()));
  cpu->fold_batch_norm();
  vk->to(Device::vulkan);
  vk->fold_batch_norm();
  const CorrectiveBinding d = make_corrective_binding(ch, bones);
  const Clip clip = retarget(load_bvh(charfix::write_temp("swing.bvh", procedural_swing_bvh())),
                             d.prepared.character.skeleton, mat4_identity());
  const models::Normaliser norm =
      fit_norm(features_in_bone_order(make_densegats_sample(d.prepared, clip.frames[0], 0, 0).features, d.mapping), true);
  const float height = 1.0f / d.prepared.normalisation.scale;
  for (int f : {0, 3}) {
    const CorrectedFrame a = deform_frame(d, *cpu, norm, clip.frames[std::size_t(f)]);
    const CorrectedFrame b = deform_frame(d, *vk, norm, clip.frames[std::size_t(f)]);
    CHECK(a.lbs == b.lbs);
    CHECK(max_abs_diff(a.corrected, b.corrected) < 1e-4f * height);
    CHECK(max_abs_diff(a.corrected, a.lbs) > 0.0f);
  }
}

TEST_CASE("deform bakes a real character's walk (FBX2glTF bind space) for viewers", "[character][export][deform][data]") {
  const auto dir = charfix::data_dir();
  const auto src = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  const auto walk = dir / "motion" / "cmu" / "walk.bvh";
  if (dir.empty() || !std::filesystem::exists(src) || !std::filesystem::exists(walk)) {
    WARN("SKIPPED: data not found (" << src << ", " << walk << ")");
    return;
  }
  const Character ch = load_gltf(src.string());
  const std::vector<std::string> bones = bone_names(ch.skeleton);
  auto model = small_model("densegats", std::int64_t(bones.size()));
  model->fold_batch_norm();
  const CorrectiveBinding d = make_corrective_binding(ch, bones);
  const Clip clip = retarget(load_bvh(walk.string()), d.prepared.character.skeleton, mat4_identity());
  const models::Normaliser norm =
      fit_norm(features_in_bone_order(make_densegats_sample(d.prepared, clip.frames[0], 0, 0).features, d.mapping), true);
  BakedFrames baked;
  baked.fps = clip.fps;
  for (int f : {0, 40}) baked.positions.push_back(deform_frame(d, *model, norm, clip.frames[std::size_t(f)]).corrected);
  // glTF world frame: Y up, feet on the ground, a human height (metres).
  float lo = 1e9f, hi = -1e9f;
  for (std::size_t i = 1; i < baked.positions[1].size(); i += 3) lo = std::min(lo, baked.positions[1][i]), hi = std::max(hi, baked.positions[1][i]);
  CHECK(std::abs(lo) < 0.1f);
  CHECK((hi - lo > 1.0f && hi - lo < 2.5f));
  const std::string out = tmp("farmer_walk.glb");
  save_gltf_morph_animation(src.string(), ch, baked, out);
  const tinygltf::Model m = read_gltf(out);
  const Character back = load_gltf(out);
  // The bake's clip makes skinning the identity on the file's bind-space mesh ...
  REQUIRE(back.clips.size() == read_gltf(src.string()).animations.size() + 1);
  const Clip& held = back.clips.back();
  CHECK(max_abs_diff(linear_blend_skinning(back.mesh, skinning_matrices(back.skeleton, held.frames.at(0))),
                     back.mesh.positions) < 1e-3f);
  // ... and every primitive's base + target f is frame f in the world frame.
  const std::vector<float> want = file_vertex_positions(ch, baked.positions[1]);
  for (const SourcePrimitive& sp : ch.primitives) {
    const auto& prim = m.meshes.at(std::size_t(sp.mesh)).primitives.at(std::size_t(sp.primitive));
    REQUIRE(prim.targets.size() >= 2);
    const std::size_t t = prim.targets.size() - 1;
    std::vector<float> shown = floats(m, prim.targets[t].at("POSITION"));
    const std::vector<float> base = floats(m, prim.attributes.at("POSITION"));
    float err = 0;
    for (std::size_t i = 0; i < shown.size(); ++i)
      err = std::max(err, std::abs(shown[i] + base[i] - want[3 * std::size_t(sp.first_vertex) + i]));
    CHECK(err < 1e-4f);
  }
}

TEST_CASE("predicted weights for a real multi-primitive character re-import through the weld map",
          "[character][export][weights][data]") {
  const auto dir = charfix::data_dir();
  const auto src = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  if (dir.empty() || !std::filesystem::exists(src)) {
    WARN("SKIPPED: data not found (" << src << ")");
    return;
  }
  const Character ch = load_gltf(src.string());
  REQUIRE(ch.primitives.size() > 1);
  const std::vector<std::string> bones = bone_names(ch.skeleton);
  auto model = small_model("neuroskinning", std::int64_t(bones.size()));
  const PreparedCharacter pc = prepare_character(ch);
  const BoneMapping map = map_bones(ch.skeleton, bones, {}, "Farmer");
  const models::Normaliser norm = fit_norm(features_in_bone_order(make_neuroskinning_sample(pc).features, map), false);
  const WeightPrediction p = predict_skin_weights(*model, norm, bones, ch, 4);
  const std::string out = tmp("farmer_weights.glb");
  save_gltf_with_weights(src.string(), ch, p.weights, out, 4);
  const Character back = load_gltf(out);
  CHECK(back.welded_from_file == ch.welded_from_file);
  CHECK(back.mesh.positions == ch.mesh.positions);
  CHECK(back.mesh.weights.joint == p.weights.joint);
  REQUIRE(back.mesh.weights.weight.size() == p.weights.weight.size());
  float worst = 0;
  for (std::size_t k = 0; k < p.weights.weight.size(); ++k)
    worst = std::max(worst, std::abs(back.mesh.weights.weight[k] - p.weights.weight[k]));
  CHECK(worst < 1e-6f);
  const tinygltf::Model a = read_gltf(src.string()), b = read_gltf(out);
  CHECK(b.materials.size() == a.materials.size());
  CHECK(b.images.size() == a.images.size());
  CHECK(b.textures.size() == a.textures.size());
  CHECK(b.animations.size() == a.animations.size());
  CHECK(b.meshes.size() == a.meshes.size());
}

TEST_CASE("point caches: one per object in the object's vertex order, Blender's Z-up and start frame on request",
          "[character][export][pc2]") {
  // Two objects of one mesh: the character's own node and an unnamed copy
  // (Blender calls it Node_<index>), as a multi-mesh character has.
  tinygltf::Model m = read_gltf(humanoid_glb(5));
  REQUIRE(m.nodes[0].mesh == 0);
  tinygltf::Node copy = m.nodes[0];
  copy.name.clear();
  copy.children.clear();
  m.nodes.push_back(copy);
  const int copy_index = int(m.nodes.size()) - 1;
  m.scenes[0].nodes.push_back(copy_index);
  const std::string src = tmp("humanoid_two_objects.glb");
  tinygltf::TinyGLTF g;
  REQUIRE(g.WriteGltfSceneToFile(&m, src, true, true, false, true));
  const Character ch = load_gltf(src);
  REQUIRE(ch.primitives.size() == 2);

  BakedFrames frames;
  frames.positions = {ch.mesh.positions, ch.mesh.positions};
  for (std::size_t i = 0; i < frames.positions[1].size(); ++i) frames.positions[1][i] += 0.01f * float(i % 5);
  const auto caches = object_point_caches(ch, frames, UpAxis::z, 1.0f);
  REQUIRE(caches.size() == 2);
  CHECK(caches[0].object == m.nodes[0].name);
  CHECK(caches[1].object == "Node_" + std::to_string(copy_index));
  for (std::size_t o = 0; o < 2; ++o) {
    const SourcePrimitive& sp = ch.primitives[o];
    const PointCache& pc = caches[o].cache;
    CHECK(pc.num_points == sp.num_vertices);
    CHECK(pc.start_frame == 1.0f);
    REQUIRE(pc.samples.size() == 2);
    for (std::size_t f = 0; f < 2; ++f)
      for (std::int64_t i = 0; i < sp.num_vertices; ++i) {
        const float* w = &frames.positions[f][3 * std::size_t(ch.welded_from_file[std::size_t(sp.first_vertex + i)])];
        const float* p = &pc.samples[f][3 * std::size_t(i)];
        CHECK(p[0] == w[0]);  // Blender's Z-up: (x, y, z) -> (x, -z, y)
        CHECK(p[1] == -w[2]);
        CHECK(p[2] == w[1]);
      }
  }
  // Y-up keeps the file's frame.
  const auto y_up = object_point_caches(ch, frames, UpAxis::y, 0.0f);
  const auto file = file_vertex_positions(ch, frames.positions[1]);
  const auto& second = y_up[1].cache.samples[1];
  REQUIRE(second.size() == 3 * std::size_t(ch.primitives[1].num_vertices));
  CHECK(std::equal(second.begin(), second.end(), file.begin() + 3 * ch.primitives[1].first_vertex));

  // Files: named after the objects, all written and read back, or none.
  const std::string base = tmp("walk.pc2");
  const auto paths = object_point_cache_paths(base, caches);
  REQUIRE(paths.size() == 2);
  CHECK(paths[0] == tmp("walk_procedural_humanoid_5.pc2"));
  CHECK(paths[1] == tmp("walk_Node_" + std::to_string(copy_index) + ".pc2"));
  for (const auto& p : paths) std::filesystem::remove(p);
  CHECK(write_object_point_caches(base, caches) == paths);
  for (std::size_t o = 0; o < 2; ++o) {
    const PointCache back = read_point_cache(paths[o]);
    CHECK(back.num_points == caches[o].cache.num_points);
    CHECK(back.start_frame == 1.0f);
    CHECK(back.samples == caches[o].cache.samples);
  }
  CHECK(!std::filesystem::exists(base));
  // One object: the path as given.
  const Character one = load_gltf(humanoid_glb(5));
  CHECK(object_point_cache_paths(base, object_point_caches(one, {"deform", 30.0f, {one.mesh.positions}}, UpAxis::y, 1))
        == std::vector<std::string>{base});
  // A failed write leaves none of them.
  auto bad = caches;
  bad[1].cache.samples[0][0] = std::nanf("");
  const std::string base2 = tmp("walk_bad.pc2");
  CHECK_THROWS_WITH(write_object_point_caches(base2, bad), Catch::Matchers::Contains("non-finite"));
  for (const auto& p : object_point_cache_paths(base2, bad)) CHECK(!std::filesystem::exists(p));
}
