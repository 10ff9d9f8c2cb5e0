// Per-joint pose limit tables: glob matching, the built-in humanoid table,
// JSON round trip, parse errors naming the file / field / value, sampled
// poses within the limits, and (with ../shared/data) that the humanoid
// table's hinges bend the right way on the Quaternius rigs.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/joint_limits.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

// The local rotation of joint j relative to its rest rotation, as the XYZ
// Euler angles random_pose composes (q = Rx(a) Ry(b) Rz(c)).
Vec3 euler_xyz(const Quat& rest, const Quat& posed) {
  const Quat inv_rest = {-rest[0], -rest[1], -rest[2], rest[3]};
  const Quat q = quat_mul(inv_rest, posed);
  const double x = q[0], y = q[1], z = q[2], w = q[3];
  // Rotation matrix of q; for R = Rx Ry Rz: R02 = sin b, R12 = -sin a cos b,
  // R22 = cos a cos b, R01 = -cos b sin c, R00 = cos b cos c.
  const double r00 = 1 - 2 * (y * y + z * z), r01 = 2 * (x * y - z * w), r02 = 2 * (x * z + y * w);
  const double r12 = 2 * (y * z - x * w), r22 = 1 - 2 * (x * x + y * y);
  const double b = std::asin(std::clamp(r02, -1.0, 1.0));
  const double a = std::atan2(-r12, r22), c = std::atan2(-r01, r00);
  return {float(a), float(b), float(c)};
}

std::string write_file(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / name;
  std::ofstream(p) << text;
  return p.string();
}

}  // namespace

TEST_CASE("glob patterns match whole normalised names", "[character][limits]") {
  CHECK(glob_match("lowerleg.*", "lowerleg.l"));
  CHECK(glob_match("index*", "index2.r"));
  CHECK(glob_match("?ead", "head"));
  CHECK(glob_match("*", ""));
  CHECK_FALSE(glob_match("lowerleg.*", "upperleg.l"));
  CHECK_FALSE(glob_match("head", "forehead"));
  CHECK_FALSE(glob_match("hand.?", "hand.lx"));
}

TEST_CASE("the humanoid table maps Quaternius-style names; unknown joints get the fallback", "[character][limits]") {
  const JointLimitTable t = JointLimitTable::default_humanoid();
  Skeleton s;
  s.names = {"Root", "Hips", "LowerLeg.L", "Index2.R", "Tail_03"};
  s.parents = {-1, 0, 1, 1, 1};
  std::vector<std::string> matched;
  const auto l = t.limits_for(s, &matched);
  REQUIRE(l.size() == 5);
  CHECK(matched[0] == "(root: rest)");
  CHECK(matched[2] == "lowerleg.*");
  CHECK(matched[3] == "index*");
  CHECK(matched[4] == "(default)");
  for (int a = 0; a < 3; ++a) CHECK(l[0].lo[a] == 0.0f);
  // Knees are hinges: a wide range on one axis, almost none on the others.
  CHECK(l[2].hi[0] - l[2].lo[0] > 1.5f);
  CHECK(l[2].hi[2] - l[2].lo[2] < 0.2f);
  CHECK(l[4].hi[0] == Approx(10.0 * M_PI / 180.0));
}

TEST_CASE("joint-limit tables round-trip through JSON", "[character][limits]") {
  const JointLimitTable t = JointLimitTable::default_humanoid();
  const JointLimitTable u = parse_joint_limits(joint_limits_json(t), "roundtrip");
  REQUIRE(u.rules.size() == t.rules.size());
  CHECK(u.name == "humanoid");
  for (std::size_t i = 0; i < t.rules.size(); ++i) {
    CHECK(u.rules[i].pattern == t.rules[i].pattern);
    for (int a = 0; a < 3; ++a) {
      CHECK(u.rules[i].degrees.lo[a] == t.rules[i].degrees.lo[a]);
      CHECK(u.rules[i].degrees.hi[a] == t.rules[i].degrees.hi[a]);
    }
  }
  JointLimitTable w = t;
  w.rules.push_back({"hip*", {}, {true, -30.0f, 115.0f}});
  const JointLimitTable wu = parse_joint_limits(joint_limits_json(w), "roundtrip");
  CHECK(wu.rules.back().flex.enabled);
  CHECK(wu.rules.back().flex.lo == -30.0f);
  CHECK(wu.rules.back().flex.hi == 115.0f);
  CHECK_FALSE(wu.rules.front().flex.enabled);
  const auto path = write_file("gatcore_limits_ok.json",
                               R"({"format": "gatcore-joint-limits", "version": 1, "default": {"x": [-5, 5]},
                                   "joints": [{"match": "knee*", "x": [0, 90]}]})");
  const JointLimitTable f = load_joint_limits(path);
  CHECK(f.name == path);
  CHECK(f.fallback_degrees.hi[0] == 5.0f);
  CHECK(f.fallback_degrees.hi[1] == 0.0f);  // absent axes are fixed
  CHECK(f.rules.at(0).degrees.hi[0] == 90.0f);
}

TEST_CASE("bad joint-limit tables are rejected naming the file, the field and the value", "[character][limits]") {
  const std::string head = R"({"format": "gatcore-joint-limits", "version": 1, )";
  struct Case {
    const char* body;
    std::vector<const char*> expect;
  };
  const std::vector<Case> cases = {
      {R"("default": {"x": [10, -10]}})", {"default.x", "min 10 is above max -10"}},
      {R"("default": {"x": [0, 0]}, "joints": [{"match": "knee*", "y": [0, "a"]}]})", {"joints[0].y", "[0,\"a\"]"}},
      {R"("default": {"x": [0, 0]}, "joints": [{"match": "", "x": [0, 1]}]})", {"joints[0].match", "\"\""}},
      {R"("default": {"x": [0, 0]}, "joints": [{"match": "a", "w": [0, 1]}]})", {"joints[0]", "unknown field \"w\""}},
      {R"("default": {"z": [-200, 0]}})", {"default.z", "[-200,0]"}},
      {R"("joints": []})", {"missing field \"default\""}},
      {R"("default": {}, "extra": 1})", {"unknown field \"extra\""}},
      {R"("default": {"flex": [0, 90]}})", {"default", "unknown field \"flex\""}},
      {R"("default": {}, "joints": [{"match": "a", "flex": [90, 0]}]})", {"joints[0].flex", "min 90 is above max 0"}},
      {R"("default": {}, "joints": [{"match": "a", "flex": 90}]})", {"joints[0].flex", "90"}},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const auto path = write_file("gatcore_limits_bad" + std::to_string(i) + ".json", head + cases[i].body);
    INFO(cases[i].body);
    try {
      (void)load_joint_limits(path);
      FAIL("accepted a bad table");
    } catch (const gatcore::InvalidArgument& e) {
      CHECK_THAT(e.what(), Contains(path));
      for (const char* x : cases[i].expect) CHECK_THAT(e.what(), Contains(x));
    }
  }
  const auto v2 = write_file("gatcore_limits_v2.json", R"({"format": "gatcore-joint-limits", "version": 2, "default": {}})");
  CHECK_THROWS_WITH(load_joint_limits(v2), Contains(v2) && Contains("\"version\"") && Contains("2"));
  const auto nojson = write_file("gatcore_limits_nojson.json", "{\"format\": ");
  CHECK_THROWS_WITH(load_joint_limits(nojson), Contains(nojson) && Contains("not a JSON joint-limit table"));
  CHECK_THROWS_WITH(load_joint_limits("/nonexistent/limits.json"), Contains("/nonexistent/limits.json"));
}

TEST_CASE("random poses sampled with the humanoid table stay within every joint's limits", "[character][limits]") {
  ProceduralOptions o;
  o.kind = ProceduralKind::humanoid;
  o.seed = 3;
  const Character ch = procedural_character(o);
  const Pose rest = rest_pose(ch.skeleton);
  const auto limits = JointLimitTable::default_humanoid().limits_for(ch.skeleton);
  std::mt19937 rng(11);
  int moved = 0;
  for (int k = 0; k < 200; ++k) {
    const Pose p = random_pose(ch.skeleton, rest, limits, rng);
    for (std::int32_t j = 0; j < ch.skeleton.num_joints(); ++j) {
      const Vec3 e = euler_xyz(rest.local[j].rotation, p.local[j].rotation);
      for (int a = 0; a < 3; ++a) {
        INFO("pose " << k << " joint " << ch.skeleton.names[j] << " axis " << a << " angle " << e[a]);
        CHECK(e[a] >= limits[j].lo[a] - 1e-3f);
        CHECK(e[a] <= limits[j].hi[a] + 1e-3f);
        moved += std::abs(e[a]) > 1e-3f;
      }
    }
  }
  CHECK(moved > 100);  // the sampler does move the joints
}

TEST_CASE("datasets record the joint-limit table and sample within it", "[character][limits]") {
  DatasetDescription s;
  s.random_poses = 4;
  s.joint_limits = JointLimitTable::default_humanoid();
  const DatasetDescription d = describe_dataset({"procedural:humanoid:1", "procedural:humanoid:2",
                                                 "procedural:humanoid:3"}, {}, s);
  const auto path = (std::filesystem::temp_directory_path() / "gatcore_limits_dataset.json").string();
  save_dataset(path, d);
  const DatasetDescription e = load_dataset(path);
  REQUIRE(e.joint_limits.has_value());
  CHECK(e.joint_limits->name == "humanoid");
  CHECK(joint_limits_json(*e.joint_limits) == joint_limits_json(*s.joint_limits));
  std::vector<PreparedCharacter> pcs;
  for (const auto& c : e.characters) pcs.push_back(prepare_character(load_dataset_character(c)));
  const std::vector<std::int32_t> all = {0, 1, 2};
  const auto tasks = dataset_tasks(e, pcs, {}, all, 0);
  REQUIRE(tasks.size() == 12);
  for (const auto& t : tasks) {
    const Skeleton& sk = pcs[t.character].character.skeleton;
    const auto lim = e.joint_limits->limits_for(sk);
    for (std::int32_t j = 0; j < sk.num_joints(); ++j) {
      const Vec3 a = euler_xyz(pcs[t.character].rest.local[j].rotation, t.pose.local[j].rotation);
      for (int k = 0; k < 3; ++k) {
        CHECK(a[k] >= lim[j].lo[k] - 1e-3f);
        CHECK(a[k] <= lim[j].hi[k] + 1e-3f);
      }
    }
  }
}

namespace {
// Hips -> UpperLeg.L -> LowerLeg.L -> Foot.L -> Toe.L, the leg hanging down
// (-Y), the toes to +Z; the upper leg's rest rotation `leg_rest`, the joints'
// world positions the same whatever it is; inverse binds from the rest; the
// first n joints.
Skeleton leg_skeleton(const Quat& leg_rest, int n = 5) {
  Skeleton s;
  const std::vector<std::pair<const char*, Vec3>> joints = {
      {"Hips", {0, 1, 0}}, {"UpperLeg.L", {0.1f, 0.95f, 0}}, {"LowerLeg.L", {0.1f, 0.5f, 0}},
      {"Foot.L", {0.1f, 0.08f, 0}}, {"Toe.L", {0.1f, 0.02f, 0.12f}}};
  std::vector<Mat4> g;
  for (int j = 0; j < n; ++j) {
    s.names.push_back(joints[std::size_t(j)].first);
    s.parents.push_back(j - 1);
    Transform t;
    const Vec3 p = joints[std::size_t(j)].second;
    if (j == 0) {
      t.translation = p;
    } else {
      const Mat4 inv = inverse(g.back());
      t.translation = transform_point(inv, p);
    }
    if (j == 1) t.rotation = leg_rest;
    // Children keep their world orientation: undo the upper leg's rotation below it.
    if (j == 2) t.rotation = {-leg_rest[0], -leg_rest[1], -leg_rest[2], leg_rest[3]};
    s.rest_local.push_back(t);
    g.push_back(j == 0 ? to_matrix(t) : mul(g.back(), to_matrix(t)));
    s.inverse_bind.push_back(inverse(g.back()));
    s.root_parent.push_back(mat4_identity());
  }
  return s;
}
}  // namespace

TEST_CASE("flexion ranges follow each rig's own flexion axis and sign", "[character][limits]") {
  JointLimitTable t;
  t.fallback_degrees = {};
  t.rules.push_back({"upperleg.*", {{-45, -20, -45}, {45, 20, 45}}, {true, -30.0f, 115.0f}});
  constexpr float r = 3.14159265f / 180.0f;
  // Identity rest: +X rotation swings the knee backwards (X x -Y = -Z), so flexion is -X.
  // Rest turned 90 degrees about Y: local Z is world +X, and -Z flexes.
  const float h = std::sqrt(0.5f);
  struct Case {
    Quat rest;
    int axis, sign;
  } cases[] = {{{0, 0, 0, 1}, 0, -1}, {{0, h, 0, h}, 2, -1}, {{0, -h, 0, h}, 2, 1}, {{0, 1, 0, 0}, 0, 1}};
  for (const Case& c : cases) {
    INFO("upper leg rest rotation " << c.rest[0] << " " << c.rest[1] << " " << c.rest[2] << " " << c.rest[3]);
    const Skeleton s = leg_skeleton(c.rest);
    Vec3 front{};
    const FlexionAxis f = flexion_axis(s, 1, &front);
    CHECK(front[2] == Approx(0.12f / std::hypot(0.06f, 0.12f)));  // foot -> toe, as given
    CHECK(f.axis == c.axis);
    CHECK(f.sign == c.sign);
    std::vector<std::string> matched;
    const auto lim = t.limits_for(s, &matched);
    CHECK_THAT(matched[1], Contains("flex"));
    const auto a = std::size_t(c.axis), other = 2 - a;
    CHECK(lim[1].lo[a] == Approx(c.sign > 0 ? -30 * r : -115 * r));
    CHECK(lim[1].hi[a] == Approx(c.sign > 0 ? 115 * r : 30 * r));
    CHECK(lim[1].lo[other] == Approx(-45 * r));  // the other axes keep the rule's ranges
    CHECK(lim[1].lo[1] == Approx(-20 * r));
    // Posed at 90 degrees of flexion, everything else at rest: the knee is in front of the hip, level with it.
    std::vector<JointLimit> only(lim.size());
    only[1].lo[a] = only[1].hi[a] = float(c.sign) * 90 * r;
    std::mt19937 rng(0);
    const auto g = global_transforms(s, random_pose(s, bind_pose(s), only, rng));
    const Vec3 hip = mat4_translation(g[1]), knee = mat4_translation(g[2]);
    CHECK(knee[2] - hip[2] == Approx(0.45f).margin(1e-3));
    CHECK(knee[1] - hip[1] == Approx(0.0f).margin(1e-3));
  }
  // No foot, no front: the rule's own ranges.
  const Skeleton n = leg_skeleton({0, 0, 0, 1}, 3);
  CHECK(flexion_axis(n, 1).axis == -1);
  std::vector<std::string> matched;
  const auto lim = t.limits_for(n, &matched);
  CHECK_THAT(matched[1], Contains("no flexion axis"));
  CHECK(lim[1].lo[0] == Approx(-45 * r));
  CHECK(lim[1].hi[0] == Approx(45 * r));
}

TEST_CASE("the humanoid table bends Quaternius knees backwards and elbows forwards, and lowers the arms", "[character][limits][data]") {
  const auto dir = charfix::data_dir();
  const auto men = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  const auto women = dir / "characters" / "quaternius" / "modular_women" / "Casual.glb";
  if (dir.empty() || !std::filesystem::exists(men) || !std::filesystem::exists(women)) {
    WARN("SKIPPED: data not found (" << men << ", " << women << ")");
    return;
  }
  const JointLimitTable t = JointLimitTable::default_humanoid();
  for (const auto& file : {men, women}) {
    const PreparedCharacter pc = prepare_character(load_gltf(file.string()));
    const Skeleton& s = pc.character.skeleton;
    const auto rest_g = global_transforms(s, pc.rest);
    const auto lim = t.limits_for(s);
    for (const char* side : {"L", "R"}) {
      const std::int32_t foot = s.find(std::string("Foot.") + side), knee = s.find(std::string("LowerLeg.") + side);
      const std::int32_t hand = s.find(std::string("Hand.") + side), elbow = s.find(std::string("LowerArm.") + side);
      REQUIRE(foot >= 0);
      REQUIRE(knee >= 0);
      REQUIRE(hand >= 0);
      REQUIRE(elbow >= 0);
      // Forward: from the ankle towards the centre of the foot's vertices.
      Vec3 c{0, 0, 0};
      double wsum = 0;
      const auto& w = pc.character.mesh.weights;
      for (std::int64_t v = 0; v < pc.character.mesh.num_vertices(); ++v)
        for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k)
          if (w.joint[k] == foot && w.weight[k] > 0.5f) {
            for (int a = 0; a < 3; ++a) c[a] += pc.character.mesh.positions[3 * v + a];
            wsum += 1;
          }
      REQUIRE(wsum > 0);
      const Vec3 ankle = mat4_translation(rest_g[foot]);
      Vec3 fwd{float(c[0] / wsum) - ankle[0], 0.0f, float(c[2] / wsum) - ankle[2]};
      const float len = std::hypot(fwd[0], fwd[2]);
      REQUIRE(len > 0);
      fwd[0] /= len, fwd[2] /= len;
      // Pose each hinge at the far end of its widest axis, everything else at rest.
      auto moved = [&](std::int32_t joint, std::int32_t tip) {
        std::vector<JointLimit> only(lim.size());
        int ax = 0;
        for (int a = 1; a < 3; ++a)
          if (lim[joint].hi[a] - lim[joint].lo[a] > lim[joint].hi[ax] - lim[joint].lo[ax]) ax = a;
        const float end = std::abs(lim[joint].hi[ax]) > std::abs(lim[joint].lo[ax]) ? lim[joint].hi[ax] : lim[joint].lo[ax];
        REQUIRE(std::abs(end) > 1.5f);  // a wide hinge
        only[joint].lo[ax] = only[joint].hi[ax] = end;
        std::mt19937 rng(0);
        const auto g = global_transforms(s, random_pose(s, pc.rest, only, rng));
        const Vec3 a = mat4_translation(rest_g[tip]), b = mat4_translation(g[tip]);
        return (b[0] - a[0]) * fwd[0] + (b[2] - a[2]) * fwd[2];
      };
      const float knee_fwd = moved(knee, foot), elbow_fwd = moved(elbow, hand);
      // A flexion range on the hips: 90 degrees of it brings the knee forwards
      // on both rigs and both sides, though they flex about different axes.
      {
        JointLimitTable ft = t;
        for (auto& rule : ft.rules)
          if (rule.pattern == "upperleg.*") rule.flex = {true, -30.0f, 115.0f};
        const std::int32_t hip = s.find(std::string("UpperLeg.") + side);
        REQUIRE(hip >= 0);
        const FlexionAxis f = flexion_axis(s, hip);
        REQUIRE(f.axis >= 0);
        const auto flim = ft.limits_for(s);
        std::vector<JointLimit> only(flim.size());
        only[hip].lo[f.axis] = only[hip].hi[f.axis] = float(f.sign) * 1.5708f;
        REQUIRE(only[hip].hi[f.axis] >= flim[hip].lo[f.axis]);
        REQUIRE(only[hip].hi[f.axis] <= flim[hip].hi[f.axis]);
        std::mt19937 rng(0);
        const auto g = global_transforms(s, random_pose(s, pc.rest, only, rng));
        const Vec3 a = mat4_translation(rest_g[knee]), b = mat4_translation(g[knee]);
        const Vec3 h = mat4_translation(rest_g[hip]);
        const float thigh = std::hypot(a[0] - h[0], a[1] - h[1], a[2] - h[2]);
        const float fwd_move = (b[0] - a[0]) * fwd[0] + (b[2] - a[2]) * fwd[2];
        INFO(file << " side " << side << ": hip flexion axis " << f.axis << " sign " << f.sign << ", the knee moves "
                  << fwd_move / thigh << " thigh lengths forward and " << (b[1] - a[1]) / thigh << " up");
        CHECK(fwd_move > 0.8f * thigh);
        CHECK(b[1] - a[1] > 0.8f * thigh);
      }
      INFO(file << " side " << side << ": ankle moves " << knee_fwd << " forward, wrist " << elbow_fwd);
      CHECK(knee_fwd < 0.0f);
      CHECK(elbow_fwd > 0.0f);
      // The T-pose's arms must be able to hang down (walking keeps them
      // there): the upper arm's X lower limit points the elbow straight down.
      const std::int32_t shoulder = s.find(std::string("UpperArm.") + side);
      REQUIRE(shoulder >= 0);
      std::vector<JointLimit> down(lim.size());
      down[shoulder].lo[0] = down[shoulder].hi[0] = lim[shoulder].lo[0];
      std::mt19937 rng(0);
      const auto g = global_transforms(s, random_pose(s, pc.rest, down, rng));
      const Vec3 a = mat4_translation(g[shoulder]), b = mat4_translation(g[elbow]);
      const float arm = std::sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
      INFO("upper arm at its X lower limit points along y " << (b[1] - a[1]) / arm);
      CHECK((b[1] - a[1]) / arm < -0.95f);
    }
  }
}

TEST_CASE("pose_limit_excess: zero within the limits, the overshoot outside them, roots ignored", "[character][limits]") {
  const Character ch = procedural_character({});
  const Pose rest = bind_pose(ch.skeleton);
  const std::vector<JointLimit> limits = JointLimitTable::default_humanoid().limits_for(ch.skeleton);
  std::mt19937 rng(5);
  for (int i = 0; i < 20; ++i) {
    const Pose p = random_pose(ch.skeleton, rest, limits, rng);
    CHECK(pose_limit_excess(ch.skeleton, rest, p, limits).radians < 1e-4f);
  }
  // One non-root joint turned 0.3 rad past its upper X limit.
  std::int32_t j = -1;
  for (std::int32_t k = 0; k < ch.skeleton.num_joints() && j < 0; ++k)
    if (ch.skeleton.parents[std::size_t(k)] >= 0 && limits[std::size_t(k)].hi[0] < 1.0f) j = k;
  REQUIRE(j >= 0);
  Pose p = rest;
  p.local[std::size_t(j)].rotation =
      quat_mul(rest.local[std::size_t(j)].rotation, quat_from_axis_angle({1, 0, 0}, limits[std::size_t(j)].hi[0] + 0.3f));
  const LimitExcess e = pose_limit_excess(ch.skeleton, rest, p, limits);
  CHECK(e.radians == Approx(0.3f).margin(1e-4));
  CHECK(e.joint == j);
  CHECK(e.axis == 0);
  // The root's own rotation (the motion's root movement) does not count.
  Pose moved = rest;
  moved.local[0].rotation = quat_mul(quat_from_axis_angle({0, 1, 0}, 2.0f), rest.local[0].rotation);
  CHECK(pose_limit_excess(ch.skeleton, rest, moved, limits).radians == 0.0f);
  // Neither does the orientation joint (and its ancestors) when named.
  CHECK(pose_limit_excess(ch.skeleton, rest, p, limits, j).radians == 0.0f);
  CHECK(pose_limit_excess(ch.skeleton, rest, p, limits, 0).radians == Approx(0.3f).margin(1e-4));
  CHECK_THROWS_WITH(pose_limit_excess(ch.skeleton, rest, p, {}), Contains("0 limits"));

  // Legs on a root beside the hips (Root -> Hips, Root -> UpperLeg): a body
  // turned round turns the hips and, relative to Root, the thigh with them;
  // that is the orientation, not the thigh's own rotation.
  Skeleton r;
  r.names = {"Root", "Hips", "UpperLeg.L", "LowerLeg.L"};
  r.parents = {-1, 0, 0, 2};
  const std::vector<Vec3> at = {{0, 0, 0}, {0, 1, 0}, {0.1f, 0.95f, 0}, {0.1f, 0.5f, 0}};
  for (std::size_t k = 0; k < at.size(); ++k) {
    Transform t;
    const std::int32_t par = r.parents[k];
    t.translation = par < 0 ? at[k] : Vec3{at[k][0] - at[std::size_t(par)][0], at[k][1] - at[std::size_t(par)][1],
                                           at[k][2] - at[std::size_t(par)][2]};
    r.rest_local.push_back(t);
    Mat4 ibm = mat4_identity();
    ibm[12] = -at[k][0], ibm[13] = -at[k][1], ibm[14] = -at[k][2];
    r.inverse_bind.push_back(ibm);
    r.root_parent.push_back(mat4_identity());
  }
  std::vector<JointLimit> small(4);
  for (auto& l : small) l.lo = {-0.2f, -0.2f, -0.2f}, l.hi = {0.2f, 0.2f, 0.2f};
  const Pose rr = bind_pose(r);
  Pose turned = rr;
  const Quat turn = quat_from_axis_angle({0, 1, 0}, 2.5f);
  turned.local[1].rotation = turn;
  turned.local[2].rotation = turn;
  CHECK(pose_limit_excess(r, rr, turned, small, 1).radians == Approx(0.0f).margin(1e-5));
  CHECK(pose_limit_excess(r, rr, turned, small).radians > 2.0f);  // without the orientation joint: read as the thigh's
  turned.local[2].rotation = quat_mul(turn, quat_from_axis_angle({1, 0, 0}, 0.5f));  // and a bend of its own
  const LimitExcess own = pose_limit_excess(r, rr, turned, small, 1);
  CHECK(own.radians == Approx(0.3f).margin(1e-4));
  CHECK(own.joint == 2);
  CHECK(own.axis == 0);
}
