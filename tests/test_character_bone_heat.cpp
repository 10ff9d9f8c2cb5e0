// Bone heat (deform/bone_heat.hpp) against the analytic falloff on a two-bone
// tube, and its robustness guarantees (garments that see no bone, isolated
// vertices, duplicated seam vertices); influence limits (rig/limit_weights.hpp).
#include <catch2/catch.hpp>

#include <cmath>
#include <map>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/rig/blend_weights.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace {

float weight_of(const SkinWeights& w, std::int64_t v, std::int32_t j) {
  for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k)
    if (w.joint[k] == j) return w.weight[k];
  return 0.0f;
}

void check_partition(const SkinWeights& w, std::int64_t n, std::int32_t joints) {
  REQUIRE(w.num_vertices() == n);
  for (std::int64_t v = 0; v < n; ++v) {
    REQUIRE(w.ptr[v + 1] > w.ptr[v]);  // no vertex without weights
    double s = 0;
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) {
      REQUIRE(w.joint[k] >= 0);
      REQUIRE(w.joint[k] < joints);
      REQUIRE(w.weight[k] > 0.0f);
      s += w.weight[k];
    }
    REQUIRE(s == Approx(1.0).epsilon(1e-5));
  }
}

}  // namespace

TEST_CASE("bone heat on a two-bone tube follows the analytic exponential falloff", "[bone_heat]") {
  // Tube y in [0, 2], radius r = 0.25, joints at y = 0 and 1. Every side
  // vertex is at distance r from its nearest bone (root below y = 1, bone1
  // above), so H = 1 / r^2 and, axially symmetric, -w'' + (w - p) / r^2 = 0:
  // w_bone1(y) = 0.5 exp(-(1 - y) / r) below the joint and
  // 1 - 0.5 exp(-(y - 1) / r) above it.
  const float r = 0.25f;
  const int rings = 81, segments = 32;
  const Character ch = charfix::tube_character(rings, segments, 2.0f, r, 0.0f);
  BoneHeatParams p;
  p.heat = 1.0f;
  p.max_influences = 2;
  p.min_weight = 0.0f;
  p.cut_below = 0.0f;  // the solved heat itself
  const SkinWeights w = bone_heat_weights(ch, p);
  check_partition(w, ch.mesh.num_vertices(), 2);
  double max_err = 0;
  int checked = 0;
  for (int ring = 0; ring < rings; ++ring) {
    const double y = 2.0 * ring / (rings - 1);
    if (y < 0.4 || y > 1.6 || std::abs(y - 1.0) < 1e-6) continue;
    const double expect = y < 1 ? 0.5 * std::exp(-(1 - y) / r) : 1 - 0.5 * std::exp(-(y - 1) / r);
    for (int c = 0; c < segments; ++c) {
      const std::int64_t v = static_cast<std::int64_t>(ring) * segments + c;
      REQUIRE(std::abs(ch.mesh.positions[3 * v + 1] - y) < 1e-5);
      max_err = std::max(max_err, std::abs(double(weight_of(w, v, 1)) - expect));
      ++checked;
    }
  }
  REQUIRE(checked > 0);
  INFO("max |w - analytic| = " << max_err);
  CHECK(max_err < 0.03);
  // Symmetric about the joint, monotone along the tube.
  for (int ring = 1; ring < rings; ++ring)
    CHECK(weight_of(w, ring * segments, 1) >= weight_of(w, (ring - 1) * segments, 1) - 1e-6f);
  // A four times stronger heat halves the falloff length: sharper at y = 0.8.
  p.heat = 4.0f;
  const SkinWeights sharp = bone_heat_weights(ch, p);
  const int ring08 = static_cast<int>(std::lround(0.8 * (rings - 1) / 2.0));
  const double y08 = 2.0 * ring08 / (rings - 1);
  CHECK(weight_of(sharp, ring08 * segments, 1) == Approx(0.5 * std::exp(-2 * (1 - y08) / r)).margin(0.03));
}

TEST_CASE("bone heat leaves no vertex without weights on garments, seams and loose vertices", "[bone_heat]") {
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  const std::int64_t body = ch.mesh.num_vertices();
  // A sleeve (radius 0.35, y in [0.5, 1.5], with a UV seam): every ray from
  // it to a bone crosses the body tube, so no vertex of it sees a bone.
  const charfix::Tube g = charfix::tube_geometry(8, 16, 1.0f, 0.35f, true, false, 0.0f);
  for (std::size_t i = 0; i < g.pos.size(); ++i) ch.mesh.positions.push_back(g.pos[i] + (i % 3 == 1 ? 0.5f : 0.0f));
  for (std::int32_t t : g.tris) ch.mesh.triangles.push_back(static_cast<std::int32_t>(body + t));
  ch.mesh.positions.insert(ch.mesh.positions.end(), {1.0f, 1.0f, 1.0f});  // a vertex in no triangle
  const std::int64_t n = ch.mesh.num_vertices();
  ch.mesh.weights = SkinWeights{};
  for (std::int64_t v = 0; v < n; ++v) {
    ch.mesh.weights.joint.push_back(0);
    ch.mesh.weights.weight.push_back(1.0f);
    ch.mesh.weights.ptr.push_back(v + 1);
  }
  const SkinWeights w = bone_heat_weights(ch);
  check_partition(w, n, 2);
  // The sleeve is bound to its nearest bones (k = sqrt(c) / 0.35), with no
  // heat flowing out of its open ends: w_bone1 = 0.5 cosh(k (y - 0.5)) /
  // cosh(k / 2) below the joint, so 1 - 0.5 / cosh(k / 2) on root at y = 0.5
  // (0.943 at c = 4), and the same on bone1 at 1.5.
  const double k = std::sqrt(double(BoneHeatParams{}.heat)) / 0.35;
  const double expect = 1.0 - 0.5 / std::cosh(0.5 * k);
  CHECK(weight_of(w, body, 0) == Approx(expect).margin(0.03));
  CHECK(weight_of(w, body + 7 * 17, 1) == Approx(expect).margin(0.03));
  // Seam columns are duplicated positions: welded, so both copies agree.
  for (std::int64_t v = body; v < body + 8 * 17; v += 17)
    CHECK(weight_of(w, v, 1) == Approx(weight_of(w, v + 16, 1)).margin(1e-6));
}

TEST_CASE("bone heat names no joint but the character's, and rejects bad input", "[bone_heat]") {
  Character ch = charfix::tube_character(12, 8, 2.0f, 0.25f, 0.0f);
  const SkinWeights a = bone_heat_weights(ch);
  ch.skeleton.names = {"Hips", "mixamorig:LeftUpLeg"};  // names play no part
  const SkinWeights b = bone_heat_weights(ch);
  CHECK(a.joint == b.joint);
  CHECK(a.weight == b.weight);
  BoneHeatParams only_root;
  only_root.deforming = {1, 0};
  const SkinWeights r = bone_heat_weights(ch, only_root);
  for (std::int32_t j : r.joint) CHECK(j == 0);
  BoneHeatParams none;
  none.deforming = {0, 0};
  CHECK_THROWS_AS(bone_heat_weights(ch, none), gatcore::InvalidArgument);
  ch.mesh.positions[0] = std::nanf("");
  CHECK_THROWS_AS(bone_heat_weights(ch), gatcore::InvalidArgument);
}

TEST_CASE("limit_weights keeps the largest influences above min_weight, renormalised", "[limit_weights]") {
  SkinWeights w;
  w.ptr = {0, 4, 5};
  w.joint = {0, 1, 2, 3, 7};
  w.weight = {0.5f, 0.3f, 0.15f, 0.05f, 1.0f};
  const SkinWeights a = limit_weights(w, 3, 0.0f);
  REQUIRE(a.ptr == std::vector<std::int64_t>{0, 3, 4});
  CHECK(a.weight[0] == Approx(0.5 / 0.95));
  CHECK(a.weight[2] == Approx(0.15 / 0.95));
  const SkinWeights b = limit_weights(w, 4, 0.2f);  // 0.15 and 0.05 dropped
  REQUIRE(b.ptr == std::vector<std::int64_t>{0, 2, 3});
  CHECK(b.weight[0] == Approx(0.625));
  CHECK(b.weight[1] == Approx(0.375));
  const SkinWeights c = limit_weights(w, 4, 0.9f);  // the largest always stays
  REQUIRE(c.ptr == std::vector<std::int64_t>{0, 1, 2});
  CHECK(c.joint[0] == 0);
  CHECK(c.weight[0] == 1.0f);
  std::vector<float> dense{0.5f, 0.3f, 0.15f, 0.05f, 0.f, 0.f, 0.f, 0.f};
  const std::vector<std::uint8_t> mask{1, 0, 1, 1};
  limit_weights_dense(dense, 4, 4, 0.2f, mask);  // bone 1 masked: 0.5, 0.15 (0.05 < 0.2 * 0.7)
  CHECK(dense[0] == Approx(0.5 / 0.65));
  CHECK(dense[1] == 0.0f);
  CHECK(dense[2] == Approx(0.15 / 0.65));
  CHECK(dense[3] == 0.0f);
  CHECK(dense[4] == 0.0f);
  CHECK_THROWS_AS(limit_weights(w, 0, 0.0f), gatcore::InvalidArgument);
  CHECK_THROWS_AS(limit_weights(w, 4, 1.0f), gatcore::InvalidArgument);
}

TEST_CASE("blend_weights mixes two weight sets per vertex, keeps the largest, renormalised", "[blend_weights]") {
  SkinWeights a, b;
  a.ptr = {0, 2, 3};
  a.joint = {0, 1, 2};
  a.weight = {0.6f, 0.4f, 1.0f};
  b.ptr = {0, 2, 4};
  b.joint = {1, 3, 0, 2};
  b.weight = {0.5f, 0.5f, 0.8f, 0.2f};
  // Vertex 0 at share 0.25: joint 0 0.45, joint 1 0.3 + 0.125, joint 3 0.125;
  // the top 2 renormalised by 0.875. Vertex 1: joint 0 0.2, joint 2 0.8.
  const SkinWeights m = blend_weights(a, b, 0.25f, 2);
  REQUIRE(m.ptr == std::vector<std::int64_t>{0, 2, 4});
  REQUIRE(m.joint == std::vector<std::int32_t>{0, 1, 0, 2});
  CHECK(m.weight[0] == Approx(0.45 / 0.875));
  CHECK(m.weight[1] == Approx(0.425 / 0.875));
  CHECK(m.weight[2] == Approx(0.2));
  CHECK(m.weight[3] == Approx(0.8));
  // The ends are the inputs themselves (a joint at weight 0 is not kept).
  const SkinWeights only_a = blend_weights(a, b, 0.0f, 4), only_b = blend_weights(a, b, 1.0f, 4);
  CHECK(only_a.ptr == a.ptr);
  CHECK(only_a.joint == a.joint);
  CHECK(only_b.ptr == b.ptr);
  CHECK(only_b.joint == std::vector<std::int32_t>{1, 3, 0, 2});
  for (std::size_t k = 0; k < a.weight.size(); ++k) CHECK(only_a.weight[k] == Approx(a.weight[k]));
  for (std::size_t k = 0; k < b.weight.size(); ++k) CHECK(only_b.weight[k] == Approx(b.weight[k]));
  SkinWeights short_b = b;
  short_b.ptr.pop_back();
  short_b.joint.resize(2);
  short_b.weight.resize(2);
  CHECK_THROWS_WITH(blend_weights(a, short_b, 0.5f, 4), Catch::Contains("2 and 1 vertices"));
  CHECK_THROWS_AS(blend_weights(a, b, 1.5f, 4), gatcore::InvalidArgument);
  CHECK_THROWS_AS(blend_weights(a, b, std::nanf(""), 4), gatcore::InvalidArgument);
  CHECK_THROWS_AS(blend_weights(a, b, 0.5f, 0), gatcore::InvalidArgument);
}

namespace {

// Adds joint `name` under `parent` at the bind-space point `at` (no rotation).
void add_joint(Skeleton& s, const std::string& name, std::int32_t parent, const Vec3& at) {
  const Vec3 ph = parent >= 0 ? mat4_translation(inverse(s.inverse_bind[parent])) : Vec3{0.0f, 0.0f, 0.0f};
  Transform local;
  local.translation = {at[0] - ph[0], at[1] - ph[1], at[2] - ph[2]};
  s.names.push_back(name);
  s.parents.push_back(parent);
  s.rest_local.push_back(local);
  s.root_parent.push_back(mat4_identity());
  Transform global;
  global.translation = at;
  s.inverse_bind.push_back(inverse(to_matrix(global)));
}

}  // namespace

TEST_CASE("bone heat gives a control joint far outside the mesh no weight, and keeps a joint at the skin",
          "[bone_heat]") {
  // The tube's diagonal is about 2.1, so a joint more than 0.1 outside it is
  // a control: an IK pole target in front of the "knee" at y = 1.
  const Character plain = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  const SkinWeights base = bone_heat_weights(plain);
  Character pole = plain;
  add_joint(pole.skeleton, "PoleTarget", 0, {0.0f, 1.0f, 1.5f});
  const SkinWeights wp = bone_heat_weights(pole);
  check_partition(wp, pole.mesh.num_vertices(), 3);
  for (std::int32_t j : wp.joint) REQUIRE(j != 2);
  CHECK(wp.joint == base.joint);  // as if the control were not there
  CHECK(wp.weight == base.weight);

  // A leaf joint 0.05 outside the side (a foot joint at the sole, a hip
  // under a skirt) is a bone: it takes the skin next to it.
  Character sole = plain;
  add_joint(sole.skeleton, "Nub", 1, {0.3f, 1.5f, 0.0f});
  const SkinWeights ws = bone_heat_weights(sole);
  check_partition(ws, sole.mesh.num_vertices(), 3);
  float most = 0.0f;
  for (std::int64_t v = 0; v < sole.mesh.num_vertices(); ++v) most = std::max(most, weight_of(ws, v, 2));
  INFO("largest weight on the joint at the skin: " << most);
  CHECK(most > 0.5f);

  // A joint inside the mesh is a bone wherever its segment goes.
  Character inner = plain;
  add_joint(inner.skeleton, "Inner", 1, {0.0f, 1.8f, 0.0f});
  const SkinWeights wi = bone_heat_weights(inner);
  float inner_most = 0.0f;
  for (std::int64_t v = 0; v < inner.mesh.num_vertices(); ++v) inner_most = std::max(inner_most, weight_of(wi, v, 2));
  CHECK(inner_most > 0.5f);
}

TEST_CASE("a leaf bone ends at a joint outside its chain on its axis (an IK foot off the root)", "[bone_heat]") {
  // root at y = 0, bone1 at y = 1 (a leaf: its segment would end at y = 1.5),
  // and an IK target hanging off the root at y = 1.9, on bone1's axis: bone1
  // runs to it, and the segments of the others are unchanged.
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  const auto before = bone_segments(ch.skeleton);
  REQUIRE(before[1].size() == 1);
  CHECK(before[1][0].b[1] == Approx(1.5f));
  add_joint(ch.skeleton, "FootIK", 0, {0.0f, 1.9f, 0.0f});
  const auto after = bone_segments(ch.skeleton);
  REQUIRE(after[1].size() == 1);
  CHECK(after[1][0].b[1] == Approx(1.9f));
  // Off the axis (more than ~26 degrees) or beyond 1.5 parent lengths: no tail.
  Character off = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  add_joint(off.skeleton, "Side", 0, {0.5f, 1.6f, 0.0f});
  add_joint(off.skeleton, "Far", 0, {0.0f, 2.6f, 0.0f});
  CHECK(bone_segments(off.skeleton)[1][0].b[1] == Approx(1.5f));
}

TEST_CASE("a limb's last bone reaches an IK target off the root up to 3 parent lengths away (a long stylised shin)",
          "[bone_heat]") {
  // root at y = 0, bone1 (the thigh) at y = 1, Shin (a leaf) at y = 1.4: its
  // parent is 0.4 long, and an IK foot off the root at y = 2.4 is 2.5 parent
  // lengths down the shin's axis, where the shin ends.
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  add_joint(ch.skeleton, "Shin", 1, {0.0f, 1.4f, 0.0f});
  REQUIRE(bone_segments(ch.skeleton)[2][0].b[1] == Approx(1.6f));  // no target: half the parent's length
  Character ik = ch;
  add_joint(ik.skeleton, "FootIK", 0, {0.0f, 2.4f, 0.0f});
  CHECK(bone_segments(ik.skeleton)[2][0].b[1] == Approx(2.4f));
  // A root of its own (an IK control outside the hierarchy) marks it too.
  Character rooted = ch;
  add_joint(rooted.skeleton, "FootIK", -1, {0.0f, 2.4f, 0.0f});
  CHECK(bone_segments(rooted.skeleton)[2][0].b[1] == Approx(2.4f));
  // A joint deeper in another chain (a fin's axis crossing the spine) does not.
  Character deep = ch;
  add_joint(deep.skeleton, "Side", 0, {1.0f, 0.0f, 0.0f});
  add_joint(deep.skeleton, "Deep", 3, {0.0f, 2.4f, 0.0f});
  CHECK(bone_segments(deep.skeleton)[2][0].b[1] == Approx(1.6f));
  // Past 3 parent lengths: no tail.
  Character far = ch;
  add_joint(far.skeleton, "FootIK", 0, {0.0f, 2.65f, 0.0f});
  CHECK(bone_segments(far.skeleton)[2][0].b[1] == Approx(1.6f));
  // A root's own leaf (an IK foot pointing at a pole target) keeps 1.5
  // parent lengths: the test above.
}

TEST_CASE("a joint whose child carries the chain straight on is one bone: its other children are branches",
          "[bone_heat]") {
  // root at y = 0, Chest (bone1) at y = 1; Neck straight on at y = 1.8 and
  // two shoulders 37 degrees off the chest's direction, starting just above
  // it. The chest is one bone ending at the neck (a rig's bone has one tail);
  // the fan to every child within branch_cos (60 degrees) is the old rule.
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  add_joint(ch.skeleton, "Neck", 1, {0.0f, 1.8f, 0.0f});
  add_joint(ch.skeleton, "ShoulderL", 1, {0.3f, 1.4f, 0.0f});
  add_joint(ch.skeleton, "ShoulderR", 1, {-0.3f, 1.4f, 0.0f});
  // Two ears off the neck, neither straight on: the neck keeps its fan.
  add_joint(ch.skeleton, "EarL", 2, {0.3f, 2.2f, 0.0f});
  add_joint(ch.skeleton, "EarR", 2, {-0.3f, 2.2f, 0.0f});
  // A second child of the root (a leg): a root's children all start on it.
  add_joint(ch.skeleton, "Leg", 0, {0.4f, -0.3f, 0.0f});
  const auto seg = bone_segments(ch.skeleton);
  REQUIRE(seg[1].size() == 1);
  CHECK(seg[1][0].b[0] == Approx(0.0f).margin(1e-6));
  CHECK(seg[1][0].b[1] == Approx(1.8f));
  CHECK(seg[2].size() == 2);  // the neck: both ears
  CHECK(seg[0].size() == 2);  // the root: chest and leg
  BoneHeatParams fan;
  fan.continue_cos = 2.0f;
  const auto old = bone_segments(ch.skeleton, fan);
  CHECK(old[1].size() == 3);
  CHECK(old[2].size() == 2);
  CHECK(old[0].size() == 2);
  // The straight-on threshold is a cosine: a neck 15 degrees off the chest's
  // axis (cos 0.966 < 0.98) is no continuation, and the fan comes back.
  Character bent = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  add_joint(bent.skeleton, "Neck", 1, {0.8f * std::sin(0.2618f), 1.0f + 0.8f * std::cos(0.2618f), 0.0f});
  add_joint(bent.skeleton, "ShoulderL", 1, {0.3f, 1.4f, 0.0f});
  CHECK(bone_segments(bent.skeleton)[1].size() == 2);
  // A setting that is no number is refused, naming it.
  BoneHeatParams bad;
  bad.continue_cos = std::nanf("");
  CHECK_THROWS_WITH(bone_heat_weights(ch, bad), Catch::Contains("continue_cos"));
}

TEST_CASE("bone heat's weight limit drops a far bone's faint heat and ramps the next (Blender's)", "[bone_heat]") {
  // Three joints along a tube: every vertex gets heat from all of them, the
  // far ones faint. The limited weights are the solved heat through
  // Blender's heat_limit_weight (in double here), renormalised.
  Character ch = charfix::tube_character(41, 16, 2.0f, 0.25f, 0.0f);
  add_joint(ch.skeleton, "Tip", 1, {0.0f, 1.6f, 0.0f});
  BoneHeatParams raw_p;
  raw_p.max_influences = 64;
  raw_p.min_weight = 0.0f;
  raw_p.cut_below = 0.0f;
  BoneHeatParams lim_p = raw_p;
  lim_p.cut_below = 0.025f;
  lim_p.ramp_until = 0.05f;
  const SkinWeights raw = bone_heat_weights(ch, raw_p), lim = bone_heat_weights(ch, lim_p);
  check_partition(lim, ch.mesh.num_vertices(), 3);
  int cut = 0, ramped = 0;
  double max_err = 0;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    double w[3], sum = 0;
    for (std::int32_t j = 0; j < 3; ++j) {
      const double x = weight_of(raw, v, j);
      w[j] = x < 0.025 ? 0.0 : x < 0.05 ? (x - 0.025) / 0.025 * 0.05 : x;
      cut += x > 0 && x < 0.025;
      ramped += x >= 0.025 && x < 0.05;
      sum += w[j];
    }
    for (std::int32_t j = 0; j < 3; ++j) max_err = std::max(max_err, std::abs(w[j] / sum - weight_of(lim, v, j)));
  }
  INFO(cut << " weights cut, " << ramped << " ramped, max |limited - reference| " << max_err);
  CHECK(cut > 0);
  CHECK(ramped > 0);
  CHECK(max_err < 1e-5);
  // The default is Blender's limit.
  CHECK(BoneHeatParams{}.cut_below == 0.025f);
  CHECK(BoneHeatParams{}.ramp_until == 0.05f);
  // Bad limits are refused by name.
  for (const auto& [c, r] : {std::pair{-0.1f, 0.05f}, std::pair{0.05f, 0.025f}, std::pair{std::nanf(""), 0.05f}}) {
    BoneHeatParams bad;
    bad.cut_below = c, bad.ramp_until = r;
    CHECK_THROWS_WITH(bone_heat_weights(ch, bad), Catch::Matchers::Contains("cut_below"));
  }
}

TEST_CASE("bone heat's joint overrides: the user's word over the control rules", "[bone_heat]") {
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  const SkinWeights base = bone_heat_weights(ch);
  add_joint(ch.skeleton, "PoleTarget", 0, {0.0f, 1.0f, 1.5f});
  BoneHeatParams p;
  p.joint_override = {0, -1, 0};  // bone1 is a control: everything goes to the root
  const SkinWeights only_root = bone_heat_weights(ch, p);
  check_partition(only_root, ch.mesh.num_vertices(), 3);
  for (std::int32_t j : only_root.joint) CHECK(j == 0);
  p.joint_override = {0, 0, 1};  // the pole target is a bone again: the root's segment to it is back
  const SkinWeights with_pole = bone_heat_weights(ch, p);
  check_partition(with_pole, ch.mesh.num_vertices(), 3);
  CHECK(with_pole.weight != base.weight);
  p.joint_override = {0, 0, 0};  // no override: as decided by the rules
  CHECK(bone_heat_weights(ch, p).weight == base.weight);
  p.joint_override = {1, 1};
  CHECK_THROWS_AS(bone_heat_weights(ch, p), gatcore::InvalidArgument);
  p.joint_override = {-1, -1, -1};
  CHECK_THROWS_AS(bone_heat_weights(ch, p), gatcore::InvalidArgument);  // no joint deforms
}

TEST_CASE("only a vertex's nearest bone heats it: a piece behind the skin is not bound to a farther bone it sees",
          "[bone_heat]") {
  // A tube (bone1's segment from y = 1 to 1.5 inside it; the root a control)
  // and a small loose piece P just outside its wall at x = 0.5, y = 1.2: P's
  // nearest bone is bone1 (0.5 away), hidden by the wall; "Side", 0.7 away
  // in the open, P sees. Blender's rule heats P from neither (the piece then
  // goes to its nearest bone, bone1); Pinocchio's nearest *visible* bone
  // binds it to Side.
  Character ch = charfix::tube_character(24, 16, 2.0f, 0.25f, 0.0f);
  add_joint(ch.skeleton, "Side", 0, {1.2f, 1.2f, 0.0f});
  const std::int64_t first = ch.mesh.num_vertices();
  for (const Vec3& p : {Vec3{0.5f, 1.15f, -0.05f}, Vec3{0.5f, 1.25f, 0.0f}, Vec3{0.5f, 1.15f, 0.05f}}) {
    ch.mesh.positions.insert(ch.mesh.positions.end(), {p[0], p[1], p[2]});
    ch.mesh.weights.joint.push_back(1);
    ch.mesh.weights.weight.push_back(1.0f);
    ch.mesh.weights.ptr.push_back(static_cast<std::int64_t>(ch.mesh.weights.joint.size()));
  }
  const auto t = static_cast<std::int32_t>(first);
  ch.mesh.triangles.insert(ch.mesh.triangles.end(), {t, t + 1, t + 2});
  BoneHeatParams p;
  p.deforming = {0, 1, 1};
  const SkinWeights blender_rule = bone_heat_weights(ch, p);
  p.nearest_only = false;
  const SkinWeights pinocchio_rule = bone_heat_weights(ch, p);
  check_partition(blender_rule, ch.mesh.num_vertices(), 3);
  for (std::int64_t v = first; v < first + 3; ++v) {
    CHECK(weight_of(blender_rule, v, 1) > 0.99f);
    CHECK(weight_of(pinocchio_rule, v, 2) > 0.99f);
  }
  // The tube's own skin sees bone1 either way.
  const std::int64_t mid = 0.6 * first;  // a ring at about y = 1.2
  CHECK(weight_of(blender_rule, mid, 1) == Approx(weight_of(pinocchio_rule, mid, 1)).margin(1e-3));
}

TEST_CASE("facing distance: a surface goes to the bone behind it, not to a nearer one it faces", "[bone_heat]") {
  // A torso bone R along y at x = 0 and an arm bone A parallel to it at
  // x = 0.8; a patch of torso skin at x = 0.5 facing +x (towards the arm,
  // like the chest under an arm). A is nearer (0.3 against 0.5), but the
  // skin faces it: with facing_distance the patch goes to R, without to A.
  Character ch;
  ch.name = "facing";
  add_joint(ch.skeleton, "R", -1, {0.0f, 0.0f, 0.0f});
  add_joint(ch.skeleton, "T", 0, {0.0f, 2.0f, 0.0f});
  add_joint(ch.skeleton, "A", 0, {0.8f, 0.6f, 0.0f});
  add_joint(ch.skeleton, "A2", 2, {0.8f, 1.6f, 0.0f});
  const int k = 5;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      ch.mesh.positions.insert(ch.mesh.positions.end(), {0.5f, 0.8f + 0.1f * i, -0.2f + 0.1f * j});
      ch.mesh.weights.joint.push_back(0);
      ch.mesh.weights.weight.push_back(1.0f);
      ch.mesh.weights.ptr.push_back(static_cast<std::int64_t>(ch.mesh.weights.joint.size()));
    }
  for (int i = 0; i + 1 < k; ++i)
    for (int j = 0; j + 1 < k; ++j) {
      // (y, z) grid wound so that the normal is +x.
      const std::int32_t a = i * k + j, b = (i + 1) * k + j, c = a + 1, d = b + 1;
      ch.mesh.triangles.insert(ch.mesh.triangles.end(), {a, b, c, c, b, d});
    }
  BoneHeatParams p;
  p.deforming = {1, 1, 1, 1};
  p.max_influences = 1;
  const SkinWeights facing = bone_heat_weights(ch, p);
  p.facing_distance = false;
  const SkinWeights nearest = bone_heat_weights(ch, p);
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    CHECK(weight_of(facing, v, 0) == 1.0f);
    CHECK(weight_of(nearest, v, 2) == 1.0f);
  }
  // Wound the other way (normal -x), the arm is both nearer and behind the
  // skin: A.
  for (std::size_t t = 0; t < ch.mesh.triangles.size(); t += 3) std::swap(ch.mesh.triangles[t + 1], ch.mesh.triangles[t + 2]);
  p.facing_distance = true;
  const SkinWeights flipped = bone_heat_weights(ch, p);
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) CHECK(weight_of(flipped, v, 2) == 1.0f);
}
