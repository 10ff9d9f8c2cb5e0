// Rig conventions: every tested convention recognised and mapped by
// itself (as a glTF character and as a BVH motion), a known pose moved from
// every convention onto every other, and loud refusals for rigs that cannot
// be mapped. The rigs come from tests/rig_fixtures.hpp (written from code).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "character_fixtures.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/error.hpp"
#include "rig_fixtures.hpp"
#include "src/character/rig/weld.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

// Each joint's landmark (what it is on the common body), by joint name.
std::map<std::string, std::string> landmarks(const rigfix::Spec& s, bool bvh) {
  std::map<std::string, std::string> out;
  const auto e = rigfix::expand(s);
  std::size_t j = 0;
  for (const rigfix::Joint& jt : s.joints) {
    const bool sided = jt.name.find('<') != std::string::npos;
    for (int k = 0; k < (sided ? 2 : 1); ++k, ++j) {
      std::string w = jt.where;
      const bool ls = w.find('<') != std::string::npos;
      for (std::size_t i; (i = w.find('<')) != std::string::npos;) w.erase(i, 1);
      out[bvh ? rigfix::bvh_name(e.names[j]) : e.names[j]] = ls ? w + (k == 0 ? ".L" : ".R") : w;
    }
  }
  return out;
}

std::string landmark_of_part(const std::string& part) {
  if (part.size() > 2 && part[part.size() - 2] == '.')
    return part.substr(0, part.size() - 2) + (part.back() == 'l' ? ".L" : ".R");
  return part;
}

// The body parts every fixture humanoid has, and what each must land on.
void check_mapping(const rigfix::Spec& spec, const Skeleton& s, const RigMapping& m, bool bvh) {
  INFO(spec.id << (bvh ? " (BVH)" : " (glTF)") << "\n" << describe_rig(s, m));
  CHECK_THAT(m.convention, StartsWith(spec.convention));
  REQUIRE(m.humanoid());
  const auto lm = landmarks(spec, bvh);
  for (const char* part : {"pelvis", "head", "upperarm.l", "upperarm.r", "forearm.l", "forearm.r", "hand.l", "hand.r",
                           "thigh.l", "thigh.r", "shin.l", "shin.r", "foot.l", "foot.r"}) {
    const std::int32_t j = m.find(part);
    INFO("part " << part);
    REQUIRE(j >= 0);
    CHECK(lm.at(s.names[j]) == landmark_of_part(part));
  }
  // Twist / roll / IK / end bones are helpers, never body parts.
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    const std::string& l = lm.at(s.names[j]);
    if (l.rfind("mid:", 0) == 0 || l.rfind("pole", 0) == 0 || l == "headtop" || l.rfind("toeend", 0) == 0) {
      INFO("joint " << s.names[j]);
      CHECK(m.role[j] != JointRole::body);
    }
  }
}

// The pose every source plays: left knee bent 45 degrees, right thigh 30
// forward, left arm 30 down, right elbow 60, left index finger curled 40,
// the whole body moved. (No pelvis
// turn: rigs whose legs hang off the root above the pelvis, like Quaternius,
// do not turn their legs with it.)
std::vector<rigfix::PartPose> known_pose() {
  rigfix::PartPose p;
  p.zxy = {{"shin.L", {0, 45, 0}}, {"thigh.R", {0, -30, 0}}, {"upperarm.L", {-30, 0, 0}},
           {"forearm.R", {0, 0, 60}}, {"finger:index:1.L", {-40, 0, 0}}};
  p.move = {0.1f, -0.05f, 0.3f};
  return {p};
}

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
float angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(dot(a, b) / std::sqrt(dot(a, a) * dot(b, b)), -1.0f, 1.0f)) * 57.29578f;
}

rigfix::Spec spec_named(const std::string& id) {
  for (const rigfix::Spec& s : rigfix::specs())
    if (s.id == id) return s;
  FAIL("no fixture rig " << id);
  return {};
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("gatcore_rig_" + name)).string();
}

}  // namespace

TEST_CASE("every rig convention maps by itself as a glTF character", "[character][rig]") {
  for (const rigfix::Spec& spec : rigfix::specs()) {
    const Character ch = rigfix::character(spec);
    const std::string path = temp_path(spec.id + ".glb");
    save_gltf_character(ch, path);
    const Character back = load_gltf(path);
    check_mapping(spec, back.skeleton, map_rig(back.skeleton), false);
  }
}

TEST_CASE("every rig convention maps by itself as a BVH motion", "[character][rig][bvh]") {
  for (const rigfix::Spec& spec : rigfix::specs()) {
    const Motion m = load_bvh(charfix::write_temp(spec.id + ".bvh", rigfix::bvh(spec, known_pose())));
    check_mapping(spec, m.skeleton, map_rig(m.skeleton), true);
  }
}

TEST_CASE("a known pose moves every mapped limb, from every convention onto every other", "[character][rig][retarget]") {
  const auto specs = rigfix::specs();
  int pairs = 0, fingers = 0;
  for (const rigfix::Spec& src : specs) {
    const Motion motion = load_bvh(charfix::write_temp(src.id + "_pose.bvh", rigfix::bvh(src, known_pose())));
    const RigMapping ms = map_rig(motion.skeleton);
    REQUIRE(motion.clip.frames.size() == 2);
    const auto sg = global_transforms(motion.skeleton, motion.clip.frames[1]);
    for (const rigfix::Spec& dst : specs) {
      INFO(src.id << " -> " << dst.id);
      const Skeleton target = rigfix::skeleton(dst);
      const RigMapping mt = map_rig(target);
      const Clip clip = retarget(motion, target, mat4_identity());
      REQUIRE(clip.frames.size() == 2);
      const auto tg = global_transforms(target, clip.frames[1]);
      auto tpos = [&](const char* part) { return mat4_translation(tg[mt.find(part)]); };
      auto spos = [&](const char* part) { return mat4_translation(sg[ms.find(part)]); };
      // The 45-degree knee bend is a 45-degree knee bend in the world frame.
      CHECK(angle_deg(sub(tpos("shin.l"), tpos("thigh.l")), sub(tpos("foot.l"), tpos("shin.l"))) ==
            Approx(45.0f).margin(1.0f));
      CHECK(angle_deg(sub(tpos("shin.r"), tpos("thigh.r")), sub(tpos("foot.r"), tpos("shin.r"))) ==
            Approx(0.0f).margin(1.0f));
      // End effectors relative to the pelvis, in metres of the common body.
      for (const char* part : {"hand.l", "hand.r", "forearm.l", "forearm.r", "foot.l", "foot.r", "shin.l", "shin.r", "head"}) {
        if (src.id == "quaternius_old" && std::string(part).rfind("foot", 0) == 0) continue;  // its IK feet stay put
        const Vec3 a = sub(spos(part), spos("pelvis")), b = sub(tpos(part), tpos("pelvis"));
        INFO(part << ": source " << a[0] / src.units << " " << a[1] / src.units << " " << a[2] / src.units << ", target "
                  << b[0] / dst.units << " " << b[1] / dst.units << " " << b[2] / dst.units);
        for (int k = 0; k < 3; ++k) CHECK(b[k] / dst.units == Approx(a[k] / src.units).margin(0.02));
      }
      // Root motion: the pelvis travels as the source's did (scaled by hip
      // heights, which differ by a few percent with and without toes).
      {
        const auto tg0 = global_transforms(target, clip.frames[0]);
        const auto sg0 = global_transforms(motion.skeleton, motion.clip.frames[0]);
        const Vec3 dt = sub(tpos("pelvis"), mat4_translation(tg0[mt.find("pelvis")]));
        const Vec3 ds = sub(spos("pelvis"), mat4_translation(sg0[ms.find("pelvis")]));
        CHECK(dt[0] / dst.units == Approx(ds[0] / src.units).epsilon(0.1));
        CHECK(dt[2] / dst.units == Approx(ds[2] / src.units).epsilon(0.1));
      }
      // Fingers move when both sides have them: the left index curls down
      // (its tip drops about 4 cm; 1 cm tolerance).
      if (ms.find("index3.l") >= 0 && mt.find("index3.l") >= 0) {
        const Vec3 a = sub(spos("index3.l"), spos("hand.l")), b = sub(tpos("index3.l"), tpos("hand.l"));
        INFO("index3.l from the hand: source " << a[0] / src.units << " " << a[1] / src.units << " " << a[2] / src.units
                                               << ", target " << b[0] / dst.units << " " << b[1] / dst.units << " "
                                               << b[2] / dst.units);
        for (int k = 0; k < 3; ++k) CHECK(b[k] / dst.units == Approx(a[k] / src.units).margin(0.01));
        ++fingers;
      }
      ++pairs;
    }
  }
  CHECK(pairs == static_cast<int>(specs.size() * specs.size()));
  CHECK(fingers >= 60);
}

TEST_CASE("a turned-round body keeps its legs at its hips, on rigs whose legs hang off the root", "[character][rig][retarget]") {
  // The CMU jump turns the actor round; the Quaternius women's thighs hang
  // off Root, not Hips. The hip joints are rigid parts of the pelvis: in the
  // pelvis's own frame they stay where the bind pose has them, however the
  // body turns (the left leg used to stay at its rest place beside the
  // unturned root, which after half a turn is the right hip).
  std::vector<rigfix::PartPose> turned = known_pose();
  turned[0].zxy["pelvis"] = {0, 0, 160};
  const Motion motion = load_bvh(charfix::write_temp("cmu_turned.bvh", rigfix::bvh(spec_named("cmu"), turned)));
  int rooted = 0;
  for (const rigfix::Spec& dst : rigfix::specs()) {
    INFO("cmu -> " << dst.id);
    const Skeleton target = rigfix::skeleton(dst);
    const RigMapping mt = map_rig(target);
    const auto g0 = global_transforms(target, world_bind_pose(target, mat4_identity()));
    const auto g1 = global_transforms(target, retarget(motion, target, mat4_identity()).frames[1]);
    const std::int32_t pelvis = mt.find("pelvis");
    REQUIRE(pelvis >= 0);
    // The pelvis did turn: its horizontal local axis swings by more than 120 degrees.
    float turn = 0;
    for (int c = 0; c < 3; ++c)
      turn = std::max(turn, angle_deg({g0[pelvis][4 * c], g0[pelvis][4 * c + 1], g0[pelvis][4 * c + 2]},
                                      {g1[pelvis][4 * c], g1[pelvis][4 * c + 1], g1[pelvis][4 * c + 2]}));
    CHECK(turn > 120.0f);
    for (const char* part : {"thigh.l", "thigh.r"}) {
      const std::int32_t t = mt.find(part);
      REQUIRE(t >= 0);
      rooted += target.parents[t] != pelvis;
      const Vec3 a = transform_point(inverse(g0[pelvis]), mat4_translation(g0[t]));
      const Vec3 b = transform_point(inverse(g1[pelvis]), mat4_translation(g1[t]));
      const Vec3 d = sub(b, a);
      INFO(part << " in the pelvis frame: bind " << a[0] << " " << a[1] << " " << a[2] << ", turned " << b[0] << " " << b[1]
                << " " << b[2]);
      CHECK(std::sqrt(dot(d, d)) < 1e-3f * std::sqrt(dot(a, a)) + 1e-5f);
    }
  }
  CHECK(rooted >= 2);  // the Quaternius fixture's thighs hang off Root
}

TEST_CASE("rigs that are not humanoids are refused by name, or get root motion only on request", "[character][rig][retarget]") {
  const rigfix::Spec cmu = spec_named("cmu");
  const Motion motion = load_bvh(charfix::write_temp("cmu_pose.bvh", rigfix::bvh(cmu, known_pose())));
  const Skeleton animal = rigfix::skeleton(rigfix::quadruped());
  const RigMapping m = map_rig(animal);
  CHECK_FALSE(m.humanoid());
  RetargetOptions opt;
  opt.target_name = "Fox.glb";
  CHECK_THROWS_AS(retarget(motion, animal, mat4_identity(), opt), gatcore::InvalidArgument);
  CHECK_THROWS_WITH(retarget(motion, animal, mat4_identity(), opt),
                    Contains("Fox.glb") && Contains("thigh.l") && Contains("FrontUpperLeg.L") && Contains("--alias"));
  // Explicitly: the root moves with the source hips, nothing else.
  opt.root_motion_only = true;
  const Clip c = retarget(motion, animal, mat4_identity(), opt);
  REQUIRE(c.frames.size() == 2);
  const auto g0 = global_transforms(animal, c.frames[0]), g1 = global_transforms(animal, c.frames[1]);
  CHECK(mat4_translation(g1[0])[2] - mat4_translation(g0[0])[2] == Approx(0.3f * 0.6f / 1.0f).margin(0.05f));
  // A source whose limbs cannot be read is refused too (no silent bind pose).
  const Motion beast = load_bvh(charfix::write_temp("beast.bvh", rigfix::bvh(rigfix::quadruped(), {})));
  const Skeleton human = rigfix::skeleton(cmu);
  CHECK_THROWS_WITH(retarget(beast, human, mat4_identity()),
                    Contains("beast.bvh") && Contains("not a humanoid") && Contains("BackUpperLeg.L"));
}

TEST_CASE("aliases (gat --alias) override the tables and map what names and structure cannot", "[character][rig]") {
  // A quadruped's back legs and front legs named as a humanoid's by hand.
  const Skeleton animal = rigfix::skeleton(rigfix::quadruped());
  BoneAliases a;
  const std::pair<const char*, const char*> pairs[] = {
      {"Body", "pelvis"},           {"BackUpperLeg.L", "thigh.l"},   {"BackUpperLeg.R", "thigh.r"},
      {"BackLowerLeg.L", "shin.l"}, {"BackLowerLeg.R", "shin.r"},    {"FrontUpperLeg.L", "LeftArm"},
      {"FrontUpperLeg.R", "RightArm"}, {"FrontLowerLeg.L", "LeftForeArm"}, {"FrontLowerLeg.R", "RightForeArm"}};
  for (const auto& [j, b] : pairs) a.pairs.push_back({normalise_bone_name(j), normalise_bone_name(b)});
  const RigMapping m = map_rig(animal, a);
  INFO(describe_rig(animal, m));
  CHECK(m.humanoid());
  CHECK(animal.names[m.find("upperarm.l")] == "FrontUpperLeg.L");
  CHECK(animal.names[m.find("thigh.r")] == "BackUpperLeg.R");
  // An alias also wins over a table entry.
  const Skeleton mix = rigfix::skeleton(spec_named("mixamo_plain"));
  BoneAliases swap;
  swap.pairs.push_back({normalise_bone_name("LeftLeg"), "thigh.l"});
  const RigMapping ms = map_rig(mix, swap);
  CHECK(mix.names[ms.find("thigh.l")] == "LeftLeg");
}

TEST_CASE("older Quaternius rigs: IK feet on the root follow the shins instead of stretching", "[character][rig][retarget]") {
  const rigfix::Spec old = spec_named("quaternius_old");
  const Skeleton target = rigfix::skeleton(old);
  const RigMapping mt = map_rig(target);
  CHECK(mt.convention == "Quaternius (older: feet on the root)");
  const Motion motion = load_bvh(charfix::write_temp("cmu_knee.bvh", rigfix::bvh(spec_named("cmu"), known_pose())));
  const Clip c = retarget(motion, target, mat4_identity());
  const auto g0 = global_transforms(target, world_bind_pose(target, mat4_identity()));
  const auto g1 = global_transforms(target, c.frames[1]);
  for (const char* side : {".l", ".r"}) {
    const std::int32_t shin = mt.find(std::string("shin") + side), foot = mt.find(std::string("foot") + side);
    const float rest = std::sqrt(dot(sub(mat4_translation(g0[foot]), mat4_translation(g0[shin])),
                                     sub(mat4_translation(g0[foot]), mat4_translation(g0[shin]))));
    const float posed = std::sqrt(dot(sub(mat4_translation(g1[foot]), mat4_translation(g1[shin])),
                                      sub(mat4_translation(g1[foot]), mat4_translation(g1[shin]))));
    CHECK(posed == Approx(rest).epsilon(1e-3));
  }
}

TEST_CASE("the shared characters map as before: Quaternius humanoids, animals refused", "[character][rig][data]") {
  const auto dir = charfix::data_dir();
  if (dir.empty()) {
    WARN("SKIPPED: data not found (../shared/data)");
    return;
  }
  const auto q = dir / "characters" / "quaternius";
  for (const char* f : {"modular_men/Farmer.glb", "modular_women/Casual.glb"}) {
    const Character ch = load_gltf((q / f).string());
    const RigMapping m = map_rig(ch.skeleton);
    INFO(f << "\n" << describe_rig(ch.skeleton, m));
    CHECK(m.convention == "Quaternius");
    CHECK(m.humanoid());
    CHECK(ch.skeleton.names[m.find("thigh.l")] == "UpperLeg.L");
    CHECK(ch.skeleton.names[m.find("spine3")] == "Chest");
  }
  const Character fox = load_gltf((q / "animals" / "Fox.glb").string());
  const RigMapping mf = map_rig(fox.skeleton);
  INFO(describe_rig(fox.skeleton, mf));
  CHECK_FALSE(mf.humanoid());
  const Character platformer = load_gltf((q / "creatures" / "platformer_game_pack_Character.glb").string());
  const RigMapping mp = map_rig(platformer.skeleton);
  INFO(describe_rig(platformer.skeleton, mp));
  CHECK(mp.convention == "Quaternius (older: feet on the root)");
  CHECK(mp.humanoid());
}

TEST_CASE("the structural fallback reads unnamed rigs whichever way they face", "[character][rig]") {
  const rigfix::Spec spec = spec_named("unnamed");
  const Skeleton s = rigfix::skeleton(spec);
  const auto lm = landmarks(spec, false);
  for (float degrees : {0.0f, 90.0f, 180.0f, -90.0f}) {
    INFO("facing turned by " << degrees);
    Transform turn;
    turn.rotation = quat_from_axis_angle({0.0f, 1.0f, 0.0f}, degrees * 3.14159265f / 180.0f);
    const RigMapping m = map_rig(s, {}, to_matrix(turn));
    INFO(describe_rig(s, m));
    CHECK(m.convention == "structural");
    REQUIRE(m.humanoid());
    for (const char* part : {"thigh.l", "shin.r", "foot.l", "upperarm.l", "forearm.r", "hand.r", "head"})
      CHECK(lm.at(s.names[m.find(part)]) == landmark_of_part(part));
  }
}

TEST_CASE("weld: positions 1e38 apart and a zero tolerance weld by distance; bad input is refused",
          "[character][rig][weld]") {
  // Finite floats whose differences overflow float (the fuzzer's glTF): the
  // cells are computed in double, the duplicates still merge, the rest stay.
  const std::vector<std::vector<std::pair<int, float>>> one(4, {{0, 1.0f}});
  Character ch;
  ch.name = "wide";
  weld_into(ch, {-3e38f, 0, 0, -3e38f, 0, 0, 3e38f, 1, 0, 0.5f, 0.5f, 0.5f}, one, {0, 2, 3, 1, 2, 3}, 1e-6f);
  CHECK(ch.welded_from_file == std::vector<std::int32_t>{0, 0, 1, 2});
  CHECK(ch.mesh.num_vertices() == 3);
  CHECK(ch.mesh.triangles == std::vector<std::int32_t>{0, 1, 2, 0, 1, 2});
  // A tolerance of 0: cells of 1e-30, far past any integer; exact duplicates only.
  Character z;
  z.name = "zero";
  weld_into(z, {0, 0, 0, 0, 0, 0, 1, 0, 0, 1, 1e-7f, 0}, one, {}, 0.0f);
  CHECK(z.welded_from_file == std::vector<std::int32_t>{0, 0, 1, 2});
  Character bad;
  bad.name = "bad";
  CHECK_THROWS_WITH(weld_into(bad, {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, one, {}, std::nanf("")),
                    Catch::Contains("bad") && Catch::Contains("weld tolerance"));
  CHECK_THROWS_WITH(weld_into(bad, {0, 0, 0, 1, 0, 0, 0, INFINITY, 0, 0, 0, 1}, one, {}, 1e-6f),
                    Catch::Contains("vertex 2 is not finite"));
}
