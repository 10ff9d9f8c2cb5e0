// NeuroSkinning's per-character weight evaluation (weight_eval.hpp) against
// hand-computed values on a rigid two-bone tube.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

// Tube from y = 0 to 2 (height 2), radius 0.25, 24 rings x 24 segments plus
// two cap centres; joint "root" at the origin, "bone1" at y = 1; blend 0:
// vertices with y < 1 belong to root only, the others to bone1 only.
PreparedCharacter rigid_tube() { return prepare_character(charfix::tube_character(24, 24, 2.0f, 0.25f, 0.0f)); }

// Dense weights over a 3-bone super skeleton in which the tube's joints are
// bones 0 and 2 (bone 1 belongs to other characters: mask 0).
const std::vector<std::int32_t> kJointToBone{0, 2};
const std::vector<std::uint8_t> kMask{1, 0, 1};

std::vector<float> dense_truth(const PreparedCharacter& pc) {
  const auto& w = pc.character.mesh.weights;
  std::vector<float> d(static_cast<std::size_t>(w.num_vertices()) * 3, 0.0f);
  for (std::int64_t v = 0; v < w.num_vertices(); ++v)
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) d[v * 3 + kJointToBone[w.joint[k]]] += w.weight[k];
  return d;
}

}  // namespace

TEST_CASE("weights_from_super maps bones back to joints and renormalises", "[character][weighteval]") {
  // 2 vertices x 4 bones; the character's joint 0 is bone 2, joint 1 is bone 0; bone 3 is not its own.
  const std::vector<float> dense{0.2f, 0.0f, 0.6f, 0.2f,  //
                                 0.0f, 0.0f, 0.0f, 1.0f};
  const SkinWeights w = weights_from_super(dense, 4, {2, 0});
  REQUIRE(w.ptr == std::vector<std::int64_t>{0, 2, 2});
  CHECK(w.joint == std::vector<std::int32_t>{0, 1});
  CHECK(w.weight[0] == Approx(0.75f));
  CHECK(w.weight[1] == Approx(0.25f));
  CHECK_THROWS_WITH(weights_from_super(dense, 4, {2, 2}), Contains("both map to bone 2"));
  CHECK_THROWS_WITH(weights_from_super(dense, 4, {5}), Contains("joint 0 maps to bone 5 of 4"));
  CHECK_THROWS_WITH(weights_from_super(dense, 3, {0}), Contains("8 weights for 3 bones"));
}

TEST_CASE("weight evaluation of a perfect prediction is exact", "[character][weighteval]") {
  const PreparedCharacter pc = rigid_tube();
  const auto truth = dense_truth(pc);
  WeightEvalOptions o;
  o.poses = 4;
  const auto r = evaluate_character_weights(pc, truth, truth, 3, kJointToBone, kMask, o);
  CHECK(r.vertices == 24 * 24 + 2);
  CHECK(r.height == Approx(2.0));
  CHECK(r.weights.precision == 1.0);
  CHECK(r.weights.recall == 1.0);
  CHECK(r.weights.l1_mean == 0.0);
  CHECK(r.deformation.mean == 0.0);
  CHECK(r.deformation.max == 0.0);
  CHECK(r.dominant == 1.0);
}

TEST_CASE("weight evaluation: everything on the root bone, hand-computed", "[character][weighteval]") {
  const PreparedCharacter pc = rigid_tube();
  const auto truth = dense_truth(pc);
  const std::int64_t n = pc.character.mesh.num_vertices();
  std::vector<float> pred(static_cast<std::size_t>(n) * 3, 0.0f);
  for (std::int64_t v = 0; v < n; ++v) pred[v * 3 + 0] = 1.0f;
  // Rings at y = 2r/23 >= 1 (r = 12..23) and the top cap centre are bone1's.
  const std::int64_t upper = 12 * 24 + 1, lower = n - upper;
  WeightEvalOptions o;
  o.poses = 0;
  const auto r = evaluate_character_weights(pc, pred, truth, 3, kJointToBone, kMask, o);
  // Every vertex selects the root; only the lower ones truly have it; each
  // vertex has exactly one true bone.
  CHECK(r.weights.precision == Approx(double(lower) / double(n)));
  CHECK(r.weights.recall == Approx(double(lower) / double(n)));
  // L1: |1 - 0| + |0 - 1| = 2 on the upper vertices, 0 below.
  CHECK(r.weights.l1_mean == Approx(2.0 * double(upper) / double(n)));
  CHECK(r.weights.l1_max == Approx(2.0));
  CHECK(r.vertex_l1.back() == Approx(2.0f));  // the top cap centre
  CHECK(r.vertex_l1.front() == 0.0f);
  CHECK(r.dominant == Approx(double(lower) / double(n)));
  // The wrong vertices are all one confusion: the artist's bone1 given to root.
  REQUIRE(r.confusions.size() == 1);
  CHECK(r.confusions[0].truth == pc.character.skeleton.names[1]);
  CHECK(r.confusions[0].predicted == pc.character.skeleton.names[0]);
  CHECK(r.confusions[0].vertices == upper);

  // --min-weight: 0.9 on the truth plus 0.1 on the other bone everywhere.
  // Unpruned every vertex selects both bones (precision 0.5, L1 0.2);
  // pruned at 0.2 the prediction is exact.
  std::vector<float> blurred(truth.size(), 0.0f);
  for (std::int64_t v = 0; v < n; ++v) {
    const bool up = truth[v * 3 + 2] > 0.5f;
    blurred[v * 3 + (up ? 2 : 0)] = 0.9f;
    blurred[v * 3 + (up ? 0 : 2)] = 0.1f;
  }
  const auto rb = evaluate_character_weights(pc, blurred, truth, 3, kJointToBone, kMask, o);
  CHECK(rb.weights.precision == Approx(0.5));
  CHECK(rb.weights.l1_mean == Approx(0.2));
  CHECK(rb.dominant == 1.0);
  CHECK(rb.confusions.empty());
  WeightEvalOptions pruned = o;
  pruned.min_weight = 0.2f;
  const auto rp = evaluate_character_weights(pc, blurred, truth, 3, kJointToBone, kMask, pruned);
  CHECK(rp.weights.precision == 1.0);
  CHECK(rp.weights.l1_mean == Approx(0.0).margin(1e-7));

  // bone1 turned 90 degrees about +z: an upper vertex p = (x, y - 1, z)
  // relative to the joint goes to (-(y - 1), x, z), the root-weighted
  // prediction stays: distance sqrt(2) * sqrt(x^2 + (y - 1)^2).
  Pose bent = pc.rest;
  bent.local[1].rotation = quat_mul(bent.local[1].rotation, quat_from_axis_angle({0.0f, 0.0f, 1.0f}, 1.5707963f));
  const std::vector<Pose> poses{pc.rest, bent};
  double sum = 0, mx = 0;
  const auto& p = pc.character.mesh.positions;
  for (std::int64_t v = 0; v < n; ++v) {
    if (p[3 * v + 1] < 1.0f - 1e-6f) continue;
    const double x = p[3 * v], y1 = p[3 * v + 1] - 1.0;
    const double d = std::sqrt(2.0) * std::sqrt(x * x + y1 * y1);
    sum += d, mx = std::max(mx, d);
  }
  const SkinWeights pw = weights_from_super(pred, 3, kJointToBone), tw = pc.character.mesh.weights;
  const DistanceStats worst1 = deformation_error(pc, pw, tw, poses, 1);  // the bent pose only
  CHECK(worst1.count == n);
  CHECK(worst1.mean == Approx(sum / double(n) / 2.0).epsilon(1e-5));
  CHECK(worst1.max == Approx(mx / 2.0).epsilon(1e-5));
  CHECK(mx == Approx(std::sqrt(2.0) * std::sqrt(1.0 + 0.0625)));  // the top ring at x = +-0.25
  // Both poses pooled: the rest pose adds n zero distances.
  const DistanceStats worst2 = deformation_error(pc, pw, tw, poses, 2);
  CHECK(worst2.count == 2 * n);
  CHECK(worst2.mean == Approx(sum / double(2 * n) / 2.0).epsilon(1e-5));
  CHECK(worst2.max == Approx(mx / 2.0).epsilon(1e-5));
  CHECK_THROWS_WITH(deformation_error(pc, weights_from_super(std::vector<float>(3, 0.0f), 3, kJointToBone), tw, poses),
                    Contains("1 predicted and") && Contains(std::to_string(n) + " vertices"));
}

TEST_CASE("dominant_confusions counts (artist's, predicted) columns, most first, within the mask", "[character][weighteval]") {
  // 5 rows x 3 columns; column 1 is masked out (its large values must not count).
  const std::vector<float> truth{1, 0, 0,  1, 0, 0,  0, 0, 1,  1, 0, 0,  0, 9, 1};
  const std::vector<float> pred{0, 0, 1,  0, 5, 1,  1, 0, 0,  1, 0, 0,  1, 0, 0};
  const std::vector<std::uint8_t> mask{1, 0, 1};
  const auto c = dominant_confusions(pred, truth, 3, mask);
  REQUIRE(c.size() == 2);
  CHECK(c[0] == std::array<std::int64_t, 3>{0, 2, 2});  // rows 0 and 1
  CHECK(c[1] == std::array<std::int64_t, 3>{2, 0, 2});  // rows 2 and 4 (row 4's 9 is masked)
  CHECK(dominant_accuracy(pred, truth, 3, mask) == Approx(0.2));
  // Unmasked, row 1 predicts column 1 and row 4's truth is column 1.
  const auto u = dominant_confusions(pred, truth, 3);
  REQUIRE(u.size() == 4);
  std::int64_t rows = 0;
  for (const auto& x : u) rows += x[2];
  CHECK(rows == 4);
  CHECK_THROWS_WITH(dominant_confusions(pred, truth, 3, std::vector<std::uint8_t>{1, 0}), Contains("mask has 2"));
  CHECK_THROWS_WITH(dominant_confusions(pred, std::vector<float>(3, 0.f), 3), Contains("dominant_confusions"));
}

TEST_CASE("weight evaluation: summary, Markdown and JSON", "[character][weighteval]") {
  CharacterWeightEval a, b;
  a.name = "men/A";
  a.vertices = 10;
  a.weights = {0.5, 1.0, 0.2, 1.5};
  a.deformation.mean = 0.01, a.deformation.max = 0.1;
  b.name = "women/B";
  b.vertices = 20;
  b.weights = {0.7, 0.8, 0.4, 1.0};
  b.deformation.mean = 0.03, b.deformation.max = 0.05;
  a.dominant = 0.9, b.dominant = 0.7;
  const auto s = summarise_weight_eval({a, b});
  CHECK(s.characters == 2);
  CHECK(s.precision == Approx(0.6));
  CHECK(s.recall == Approx(0.9));
  CHECK(s.l1_mean == Approx(0.3));
  CHECK(s.l1_max == Approx(1.5));
  CHECK(s.deform_mean == Approx(0.02));
  CHECK(s.deform_max == Approx(0.1));
  CHECK(s.dominant == Approx(0.8));
  const std::string md = weight_eval_markdown({a, b});
  CHECK_THAT(md, Contains("| men/A | 10 | 0.500 | 1.000 | 0.2000 | 1.5000 | 0.01000 | 0.1000 | 0.900 |"));
  CHECK_THAT(md, Contains("| **overall** |  | 0.600 | 0.900 | 0.3000 | 1.5000 | 0.02000 | 0.1000 | 0.800 |"));
  const auto j = nlohmann::json::parse(weight_eval_json("fc", {a, b}, WeightEvalOptions{}));
  CHECK(j.at("method") == "fc");
  CHECK(j.at("characters").size() == 2);
  CHECK(j.at("characters")[1].at("name") == "women/B");
  CHECK(j.at("overall").at("recall").get<double>() == Approx(0.9));
  CHECK(j.at("overall").at("dominant").get<double>() == Approx(0.8));
  CHECK_FALSE(j.at("characters")[0].contains("confusions"));  // only when asked for
  a.confusions = {{"Neck", "Head", 7}, {"Shin", "Foot", 3}, {"Hips", "Spine", 1}};
  const auto jc = nlohmann::json::parse(weight_eval_json("fc", {a, b}, WeightEvalOptions{}, 2));
  REQUIRE(jc.at("characters")[0].at("confusions").size() == 2);
  CHECK(jc.at("characters")[0].at("confusions")[0].at("truth") == "Neck");
  CHECK(jc.at("characters")[0].at("confusions")[0].at("predicted") == "Head");
  CHECK(jc.at("characters")[0].at("confusions")[0].at("vertices") == 7);
  CHECK(jc.at("characters")[1].at("confusions").empty());
  const std::string cm = weight_eval_confusions_markdown({a, b}, 2);
  CHECK_THAT(cm, Contains("- men/A: Neck -> Head: 7, Shin -> Foot: 3\n"));
  CHECK_THAT(cm, Contains("- women/B: none\n"));
  CHECK(weight_eval_confusions_markdown({a, b}, 0).empty());
  const auto path = (std::filesystem::temp_directory_path() / "gatcore_weight_eval.json").string();
  write_text_atomic(path, "{}\n");
  std::ifstream f(path);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  CHECK(text == "{}\n");
  CHECK_FALSE(std::filesystem::exists(path + ".tmp"));
  CHECK_THROWS_WITH(write_text_atomic("/nonexistent_dir_gatcore/x.json", "{}"), Contains("/nonexistent_dir_gatcore/x.json"));
}

namespace {

Skeleton named_skeleton(const std::vector<std::pair<std::string, std::int32_t>>& joints) {
  Skeleton s;
  for (const auto& [name, parent] : joints) {
    s.names.push_back(name);
    s.parents.push_back(parent);
  }
  return s;
}

}  // namespace

TEST_CASE("body regions from joint names and the hierarchy, in several naming schemes", "[character][weighteval]") {
  using R = BodyRegion;
  // Mixamo: Spine2 is the chest (the neck's parent), Spine / Spine1 the spine.
  const Skeleton mixamo = named_skeleton({{"mixamorig:Hips", -1},         {"mixamorig:Spine", 0},
                                          {"mixamorig:Spine1", 1},        {"mixamorig:Spine2", 2},
                                          {"mixamorig:Neck", 3},          {"mixamorig:Head", 4},
                                          {"mixamorig:HeadTop_End", 5},   {"mixamorig:LeftShoulder", 3},
                                          {"mixamorig:LeftArm", 7},       {"mixamorig:LeftForeArm", 8},
                                          {"mixamorig:LeftUpLeg", 0},     {"mixamorig:LeftLeg", 10},
                                          {"mixamorig:LeftFoot", 11},     {"mixamorig:LeftToeBase", 12}});
  CHECK(body_regions(mixamo) == std::vector<R>{R::hips, R::spine, R::spine, R::chest, R::neck, R::head, R::head,
                                               R::other, R::upper_arm, R::other, R::upper_leg, R::lower_leg,
                                               R::foot, R::other});
  // Quaternius: Root, Hips, Abdomen, Torso, Chest, ...; joints under the head
  // (a jaw) are the head; an unnamed joint between hips and chest is spine.
  const Skeleton quat = named_skeleton({{"Root", -1},      {"Hips", 0},        {"Abdomen", 1},   {"Mid", 2},
                                        {"Chest", 3},      {"Neck", 4},        {"Head", 5},      {"Jaw", 6},
                                        {"UpperArm.L", 4}, {"LowerArm.L", 8},  {"UpperLeg.R", 1}, {"LowerLeg.R", 10},
                                        {"Foot.R", 11}});
  CHECK(body_regions(quat) == std::vector<R>{R::other, R::hips, R::spine, R::spine, R::chest, R::neck, R::head,
                                             R::head, R::upper_arm, R::other, R::upper_leg, R::lower_leg, R::foot});
  // Unreal: pelvis, spine_01..03 (spine_03 under the neck: chest), thigh / calf.
  const Skeleton ue = named_skeleton({{"root", -1},  {"pelvis", 0},   {"spine_01", 1}, {"spine_03", 2},
                                      {"neck_01", 3}, {"head", 4},    {"upperarm_l", 3}, {"thigh_l", 1},
                                      {"calf_l", 7},  {"foot_l", 8}});
  CHECK(body_regions(ue) == std::vector<R>{R::other, R::hips, R::spine, R::chest, R::neck, R::head, R::upper_arm,
                                           R::upper_leg, R::lower_leg, R::foot});
  // Names that say nothing: all other.
  const Skeleton bare = named_skeleton({{"Node_0", -1}, {"Node_1", 0}});
  CHECK(body_regions(bare) == std::vector<R>{R::other, R::other});
}

TEST_CASE("boundary confusions count the vertices each boundary's sides trade", "[character][weighteval]") {
  using R = BodyRegion;
  // Columns: head, neck, chest, upper leg, lower leg, other.
  const std::vector<R> region{R::head, R::neck, R::chest, R::upper_leg, R::lower_leg, R::other};
  auto row = [](int c) {
    std::vector<float> r(6, 0.0f);
    r[static_cast<std::size_t>(c)] = 1.0f;
    return r;
  };
  // (artist's column, predicted column) per vertex.
  const std::vector<std::pair<int, int>> v{{0, 0}, {0, 1}, {1, 0}, {1, 1}, {1, 2}, {2, 2},
                                           {3, 4}, {4, 4}, {5, 3}, {2, 5}};
  std::vector<float> truth, pred;
  for (const auto& [t, p] : v) {
    const auto a = row(t), b = row(p);
    truth.insert(truth.end(), a.begin(), a.end());
    pred.insert(pred.end(), b.begin(), b.end());
  }
  const auto bc = boundary_confusions(pred, truth, 6, region);
  // head/neck: artist's head or neck: vertices 0-4 (5), crossed: 0->1, 1->0 (2).
  // chest/neck: neck or chest: 2, 3, 4, 5, 9 (5), crossed: 1->2 (1).
  // upper arm/chest: the chest's vertices 5 and 9 (2), none crossed (an
  // "other" column predicted is no crossing). knee: upper or lower leg: 6, 7
  // (2), crossed: 3->4 (1). ankle: the lower leg's vertex 7 (1), not
  // crossed. hips/spine has no vertices.
  REQUIRE(bc.size() == 5);
  CHECK(bc[0].boundary == Boundary::head_neck);
  CHECK(bc[0].vertices == 5);
  CHECK(bc[0].crossed == 2);
  CHECK(bc[1].boundary == Boundary::chest_neck);
  CHECK(bc[1].vertices == 5);
  CHECK(bc[1].crossed == 1);
  CHECK(bc[2].boundary == Boundary::upper_arm_chest);
  CHECK(bc[2].vertices == 2);
  CHECK(bc[2].crossed == 0);
  CHECK(bc[3].boundary == Boundary::knee);
  CHECK(bc[3].vertices == 2);
  CHECK(bc[3].crossed == 1);
  CHECK(bc[4].boundary == Boundary::ankle);
  CHECK(bc[4].vertices == 1);
  CHECK(bc[4].crossed == 0);
  CHECK(std::string(boundary_name(Boundary::upper_arm_chest)) == "upper arm/chest");
  // Masked out, the neck column is no one's dominant bone (rows with nothing
  // left go to the first column, as in dominant_accuracy): head/neck keeps
  // its 5 vertices, all on the head side, none crossed.
  const std::vector<std::uint8_t> mask{1, 0, 1, 1, 1, 1};
  const auto masked = boundary_confusions(pred, truth, 6, region, mask);
  REQUIRE(!masked.empty());
  CHECK(masked[0].boundary == Boundary::head_neck);
  CHECK(masked[0].vertices == 5);
  CHECK(masked[0].crossed == 0);
  CHECK_THROWS_WITH(boundary_confusions(pred, truth, 6, std::vector<R>(5)), Contains("5 column regions for 6"));
  // The Markdown and JSON carry them when confusions are asked for.
  CharacterWeightEval c;
  c.name = "men/A";
  c.boundaries = bc;
  const std::string md = weight_eval_confusions_markdown({c}, 1);
  CHECK_THAT(md, Contains("boundaries (crossed / vertices): head/neck 2/5; chest/neck 1/5; upper arm/chest 0/2; knee 1/2; ankle 0/1;\n"));
  CHECK_THAT(md, Contains("| head/neck | 5 | 2 | 0.400 |"));
  const auto j = nlohmann::json::parse(weight_eval_json("m", {c}, WeightEvalOptions{}, 1));
  CHECK(j.at("characters")[0].at("boundaries")[3].at("boundary") == "knee");
  CHECK(j.at("overall").at("boundaries")[0].at("crossed") == 2);
}
