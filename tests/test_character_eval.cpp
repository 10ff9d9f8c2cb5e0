// Super skeleton (semantic bone names, aliases, masks) and the papers' metrics.
#include <catch2/catch.hpp>

#include <filesystem>

#include "character_fixtures.hpp"
#include "gatcore/character/eval/metrics.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {
Skeleton named(std::vector<std::string> names) {
  Skeleton s;
  s.names = std::move(names);
  s.parents.assign(s.names.size(), -1);
  for (std::size_t j = 1; j < s.names.size(); ++j) s.parents[j] = 0;
  s.rest_local.resize(s.names.size());
  s.inverse_bind.assign(s.names.size(), mat4_identity());
  s.root_parent.assign(s.names.size(), mat4_identity());
  return s;
}
}  // namespace

TEST_CASE("bone names normalise across naming conventions", "[character][superskeleton]") {
  CHECK(normalise_bone_name("UpperArm.L") == "upperarm.l");
  CHECK(normalise_bone_name("LeftArm") == "arm.l");
  CHECK(normalise_bone_name("mixamorig:RightHand") == "hand.r");
  CHECK(normalise_bone_name("Armature|Spine_01") == "spine01");
  CHECK(normalise_bone_name("L_Thigh") == "thigh.l");
  CHECK(normalise_bone_name("thigh_r") == "thigh.r");
  CHECK(normalise_bone_name("Hips") == "hips");
  CHECK(normalise_bone_name("Left") == "left");  // nothing after the side word: a name, not a side
}

TEST_CASE("super skeleton: union of bones, aliases, masks, weights", "[character][superskeleton]") {
  const Skeleton men = named({"Hips", "Hand.L", "Index2.L", "Index3.L"});
  const Skeleton women = named({"Hips", "Hand.L", "Index1.L", "Index2.L", "Tail"});
  const SuperSkeleton plain = build_super_skeleton({&men, &women});
  CHECK(plain.names == std::vector<std::string>{"hips", "hand.l", "index2.l", "index3.l", "index1.l", "tail"});
  const SuperSkeleton ss = build_super_skeleton({&men, &women}, {BoneAliases{}, BoneAliases::quaternius_women_to_men()});
  CHECK(ss.names == std::vector<std::string>{"hips", "hand.l", "index2.l", "index3.l", "tail"});
  CHECK(ss.joint_to_bone[1] == std::vector<std::int32_t>{0, 1, 2, 3, 4});
  CHECK(ss.mask[0] == std::vector<std::uint8_t>{1, 1, 1, 1, 0});
  CHECK(ss.mask[1] == std::vector<std::uint8_t>{1, 1, 1, 1, 1});
  SkinWeights w;
  w.ptr = {0, 2, 3};
  w.joint = {2, 4, 0};
  w.weight = {0.25f, 0.75f, 1.0f};
  const auto d = super_weights(w, ss.joint_to_bone[1], ss.num_bones());
  CHECK(d == std::vector<float>{0, 0, 0.25f, 0, 0.75f, 1, 0, 0, 0, 0});
  const Skeleton clash = named({"Hand.L", "hand_l"});
  CHECK_THROWS_WITH(build_super_skeleton({&clash}), Contains("Hand.L") && Contains("hand_l") && Contains("hand.l"));
}

TEST_CASE("super skeleton of the shared humanoids", "[character][superskeleton][data]") {
  const auto dir = charfix::data_dir();
  const auto men = dir / "characters/quaternius/modular_men/Farmer.glb";
  const auto women = dir / "characters/quaternius/modular_women/Casual.glb";
  if (dir.empty() || !std::filesystem::exists(men) || !std::filesystem::exists(women)) {
    WARN("SKIPPED: data not found (" << men << ", " << women << ")");
    return;
  }
  GltfImportOptions o;
  o.load_clips = false;
  const Character a = load_gltf(men.string(), o), b = load_gltf(women.string(), o);
  const SuperSkeleton plain = build_super_skeleton({&a.skeleton, &b.skeleton});
  const SuperSkeleton ss = build_super_skeleton({&a.skeleton, &b.skeleton}, {BoneAliases{}, BoneAliases::quaternius_women_to_men()});
  CHECK(ss.num_bones() < plain.num_bones());
  CHECK(ss.num_bones() >= 51);
  for (const auto& m : ss.mask) CHECK(std::count(m.begin(), m.end(), 1) >= 49);
}

TEST_CASE("per-vertex distance error on a hand-computed case", "[character][metrics]") {
  // Two frames, two vertices: distances 0, 5 | 1, 2.
  const std::vector<std::vector<float>> ref = {{0, 0, 0, 0, 0, 0}, {0, 0, 0, 1, 1, 1}};
  const std::vector<std::vector<float>> pred = {{0, 0, 0, 3, 4, 0}, {0, 0, 1, 1, 1, 3}};
  const DistanceStats s = vertex_distance_error(pred, ref);
  CHECK(s.count == 4);
  CHECK(s.mean == Approx(2.0));
  CHECK(s.max == Approx(5.0));
  CHECK(s.min == Approx(0.0));
  CHECK(vertex_distance_error(pred, ref, 100.0).mean == Approx(200.0));  // metres -> cm
  CHECK_THROWS(vertex_distance_error(pred, {ref[0]}));
}

TEST_CASE("bone selection precision / recall and L1 weight error by hand", "[character][metrics]") {
  // 2 vertices x 3 bones.
  const std::vector<float> truth = {0.5f, 0.5f, 0.0f, 1.0f, 0.0f, 0.0f};
  const std::vector<float> pred = {0.6f, 0.0f, 0.4f, 0.99995f, 0.00005f, 0.0f};
  const WeightMetrics m = weight_metrics(pred, truth, 3);
  // Selected (> 1e-4): v0 {0, 2}, v1 {0}; true: v0 {0, 1}, v1 {0}. TP = 2.
  CHECK(m.precision == Approx(2.0 / 3.0));
  CHECK(m.recall == Approx(2.0 / 3.0));
  // L1: v0 0.1 + 0.5 + 0.4 = 1.0; v1 0.00005 + 0.00005 = 0.0001.
  CHECK(m.l1_mean == Approx((1.0 + 0.0001) / 2).epsilon(1e-5));
  CHECK(m.l1_max == Approx(1.0).epsilon(1e-6));
  const std::vector<std::uint8_t> mask = {1, 0, 1};
  const WeightMetrics mm = weight_metrics(pred, truth, 3, 1e-4, mask);
  CHECK(mm.precision == Approx(2.0 / 3.0));
  CHECK(mm.recall == Approx(1.0));
  CHECK_THROWS(weight_metrics(pred, truth, 4));
}

TEST_CASE("deformation error at the two worst poses, normalised by height", "[character][metrics]") {
  const std::vector<std::vector<float>> d = {{1, 1}, {4, 2}, {0, 0}, {2, 6}};
  const DistanceStats s = worst_poses_error(d, 2.0);  // worst: poses 3 (mean 4) and 1 (mean 3)
  CHECK(s.count == 4);
  CHECK(s.mean == Approx(3.5 / 2.0));
  CHECK(s.max == Approx(3.0));
  CHECK(s.min == Approx(1.0));
  CHECK_THROWS(worst_poses_error(d, 0.0));
}
