// BVH import (assimp), retargeting, random poses.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <random>
#include <algorithm>

#include "character_fixtures.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

const char* kBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT LeftUpLeg
  {
    OFFSET 1 -1 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT LeftLeg
    {
      OFFSET 0 -4 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 -4 0
      }
    }
  }
  JOINT Spine
  {
    OFFSET 0 2 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 3 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0333333
0 10 0 0 0 0 0 0 0 0 0 0 0 0 0
0 10 1 0 0 0 90 0 0 0 0 0 0 0 0
0 10 2 0 0 0 0 0 0 0 0 0 0 0 45
)";

Vec3 pos(const std::vector<Mat4>& g, std::int32_t j) { return mat4_translation(g[j]); }

}  // namespace

TEST_CASE("BVH import of a generated motion", "[character][bvh]") {
  const Motion m = load_bvh(charfix::write_temp("small.bvh", kBvh));
  REQUIRE(m.skeleton.num_joints() == 4);
  CHECK(m.skeleton.names == std::vector<std::string>{"Hips", "LeftUpLeg", "LeftLeg", "Spine"});
  CHECK(m.skeleton.parents == std::vector<std::int32_t>{-1, 0, 1, 0});
  REQUIRE(m.clip.frames.size() == 3);
  CHECK(m.clip.fps == Approx(30.0f).epsilon(1e-3));
  const auto g0 = global_transforms(m.skeleton, m.clip.frames[0]);
  CHECK(pos(g0, 2)[1] == Approx(5.0f));
  // Frame 1: LeftUpLeg rotated 90 degrees about Z, hips moved to z = 1.
  const auto g1 = global_transforms(m.skeleton, m.clip.frames[1]);
  CHECK(pos(g1, 2)[0] == Approx(5.0f).margin(1e-4));
  CHECK(pos(g1, 2)[1] == Approx(9.0f).margin(1e-4));
  CHECK(pos(g1, 2)[2] == Approx(1.0f).margin(1e-4));
  // The rest pose is the offsets.
  const auto gr = global_transforms(m.skeleton, rest_pose(m.skeleton));
  CHECK(pos(gr, 3)[1] == Approx(2.0f));
}

TEST_CASE("BVH import rejects bad files", "[character][bvh]") {
  CHECK_THROWS_WITH(load_bvh("/nonexistent/walk.bvh"), Contains("/nonexistent/walk.bvh") && Contains("cannot open"));
  const std::string full = kBvh;
  const std::string t = charfix::write_temp("truncated.bvh", full.substr(0, full.size() / 3));
  CHECK_THROWS_AS(load_bvh(t), gatcore::InvalidArgument);
  CHECK_THROWS_WITH(load_bvh(t), Contains("truncated.bvh"));
  const std::string g = charfix::write_temp("garbage.bvh", "this is not a motion file\n");
  CHECK_THROWS_WITH(load_bvh(g), Contains("garbage.bvh"));
}

TEST_CASE("BVH import: the fuzzing shared reproducers end in a clear error", "[character][bvh]") {
  const std::string dir = std::string(GATCORE_SOURCE_DIR) + "/tests/fuzz/repro/";
  const std::pair<const char*, const char*> cases[] = {
      // assimp: heap-use-after-free, float->unsigned casts, a leaked node
      {"bvh_assimp_use_after_free.bvh", "line 3: expected 'OFFSET', found 'JOINT'"},
      {"bvh_assimp_channels_float_cast.bvh", "line 3: expected 'OFFSET', found 'CHANNELS'"},
      {"bvh_assimp_frames_float_cast.bvh", "line 3: expected 'OFFSET', found '}'"},
      {"bvh_truncated_root_leak.bvh", "the file ends"},
      // accepted before: NaN rotation -> identity, 0 frames -> 1, frame time 0 -> infinite fps
      {"cli_bvh_rotation_nan.bvh", "frame 1 joint 'Hips' Zrotation: 'nan' is not a finite number"},
      {"cli_bvh_0_frames.bvh", "Frames: 0 (the motion has no frames)"},
      {"cli_bvh_frame_time_0.bvh", "Frame Time 0 must be a positive number of seconds"},
  };
  for (const auto& [file, msg] : cases) {
    INFO(file);
    CHECK_THROWS_WITH(load_bvh(dir + file), Contains(dir + file) && Contains(msg));
  }
}

TEST_CASE("BVH import: strict about counts, numbers and structure", "[character][bvh]") {
  const std::string full = kBvh;
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string t = full;
    const auto at = t.find(from);
    REQUIRE(at != std::string::npos);
    return charfix::write_temp("edited.bvh", t.replace(at, from.size(), to));
  };
  CHECK_THROWS_WITH(load_bvh(edited("Frame Time:", "Frame Time: -0.5\nX")), Contains("Frame Time -0.5"));
  CHECK_THROWS_WITH(load_bvh(edited("Frame Time:", "Frame Time: inf\nX")), Contains("not a finite number"));
  CHECK_THROWS_WITH(load_bvh(edited("Frames:", "Frames: 99999999999\nX")), Contains("Frames: '99999999999'"));
  CHECK_THROWS_WITH(load_bvh(edited("Frames:", "Frames: -2\nX")), Contains("Frames: '-2'"));
  CHECK_THROWS_WITH(load_bvh(edited("CHANNELS 3", "CHANNELS 7")), Contains("CHANNELS count: '7'"));
  CHECK_THROWS_WITH(load_bvh(edited("Zrotation Yrotation Xrotation\n    JOINT LeftLeg", "Zrotation Zrotation Xrotation\n    JOINT LeftLeg")),
                    Contains("lists channel Zrotation twice"));
  CHECK_THROWS_WITH(load_bvh(edited("OFFSET 1 -1 0", "OFFSET 1 nan 0")), Contains("joint 'LeftUpLeg' OFFSET: 'nan'"));
  CHECK_THROWS_WITH(load_bvh(charfix::write_temp("extra.bvh", full + " 1.0\n")), Contains("more numbers than"));
  CHECK_THROWS_WITH(load_bvh(edited("Xrotation", "Wrotation")), Contains("unknown channel 'Wrotation'"));
}

TEST_CASE("BVH import: channel values round-trip into the documented rotations and translations", "[character][bvh]") {
  // A random hierarchy with random channel orders and values, written as BVH
  // text, read back and compared with the rotations composed independently
  // (product of axis rotations in the listed order, intrinsic, degrees).
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> angle(-180.f, 180.f), off(-3.f, 3.f);
  const char* axes[] = {"X", "Y", "Z"};
  const int kJoints = 12, kFrames = 5;
  std::vector<int> parent(kJoints), depth(kJoints);
  std::vector<std::array<int, 3>> order(kJoints);
  std::vector<bool> has_pos(kJoints);
  std::string text = "HIERARCHY\n";
  // Preorder: joint j's parent is an earlier joint on the current path.
  std::vector<int> path;
  for (int j = 0; j < kJoints; ++j) {
    while (!path.empty() && (rng() % 3 == 0)) {
      path.pop_back();
      text += "}\n";
    }
    if (j > 0 && path.empty()) path.push_back(0), text.pop_back(), text.pop_back();  // reopen the root
    parent[std::size_t(j)] = path.empty() ? -1 : path.back();
    order[std::size_t(j)] = {0, 1, 2};
    std::shuffle(order[std::size_t(j)].begin(), order[std::size_t(j)].end(), rng);
    has_pos[std::size_t(j)] = j == 0 || rng() % 4 == 0;
    text += std::string(j == 0 ? "ROOT" : "JOINT") + " J" + std::to_string(j) + "\n{\nOFFSET " +
            std::to_string(off(rng)) + " " + std::to_string(off(rng)) + " " + std::to_string(off(rng)) + "\nCHANNELS " +
            (has_pos[std::size_t(j)] ? "6 Xposition Yposition Zposition " : "3 ");
    for (int a : order[std::size_t(j)]) text += std::string(axes[a]) + "rotation ";
    text += "\n";
    path.push_back(j);
  }
  while (!path.empty()) path.pop_back(), text += "}\n";
  text += "MOTION\nFrames: " + std::to_string(kFrames) + "\nFrame Time: 0.025\n";
  std::vector<std::vector<float>> values(kFrames);
  for (auto& v : values) {
    for (int j = 0; j < kJoints; ++j)
      for (int k = 0; k < (has_pos[std::size_t(j)] ? 6 : 3); ++k) v.push_back(k < 3 && has_pos[std::size_t(j)] ? off(rng) : angle(rng));
    for (float x : v) text += std::to_string(x) + " ";
    text += "\n";
  }
  const Motion m = load_bvh(charfix::write_temp("roundtrip.bvh", text));
  REQUIRE(m.skeleton.num_joints() == kJoints);
  CHECK(m.clip.fps == Approx(40.0f));
  for (int j = 0; j < kJoints; ++j) CHECK(m.skeleton.parents[std::size_t(j)] == parent[std::size_t(j)]);
  for (int f = 0; f < kFrames; ++f) {
    std::size_t k = 0;
    for (int j = 0; j < kJoints; ++j) {
      const Transform& t = m.clip.frames[std::size_t(f)].local[std::size_t(j)];
      const auto& v = values[std::size_t(f)];
      Vec3 expect_pos = m.skeleton.rest_local[std::size_t(j)].translation;
      if (has_pos[std::size_t(j)]) {
        expect_pos = {std::stof(std::to_string(v[k])), std::stof(std::to_string(v[k + 1])), std::stof(std::to_string(v[k + 2]))};
        k += 3;
      }
      Quat q{0, 0, 0, 1};
      for (int a : order[std::size_t(j)]) {
        Vec3 axis{0, 0, 0};
        axis[std::size_t(a)] = 1;
        q = quat_mul(q, quat_from_axis_angle(axis, std::stof(std::to_string(v[k++])) * float(M_PI / 180.0)));
      }
      for (int c = 0; c < 3; ++c) CHECK(t.translation[std::size_t(c)] == Approx(expect_pos[std::size_t(c)]).margin(1e-5));
      const float dot = std::abs(q[0] * t.rotation[0] + q[1] * t.rotation[1] + q[2] * t.rotation[2] + q[3] * t.rotation[3]);
      CHECK(dot == Approx(1.0f).margin(1e-5));
    }
  }
}

TEST_CASE("retargeting a motion onto its own skeleton reproduces it, grounded", "[character][retarget]") {
  const Motion m = load_bvh(charfix::write_temp("self.bvh", kBvh));
  RetargetMap map;
  for (const auto& n : m.skeleton.names) map.pairs.push_back({n, n});
  const Clip c = retarget(m, m.skeleton, mat4_identity(), map);
  REQUIRE(c.frames.size() == m.clip.frames.size());
  for (std::size_t f = 0; f < c.frames.size(); ++f) {
    const auto a = global_transforms(m.skeleton, m.clip.frames[f]), b = global_transforms(m.skeleton, c.frames[f]);
    // Same shape relative to the hips; the hips start at their rest place
    // and the lowest joint of the clip (y = 5) lands on the rest ground (y = -5).
    for (std::int32_t j = 0; j < m.skeleton.num_joints(); ++j)
      for (int k = 0; k < 3; ++k) CHECK(pos(b, j)[k] - pos(b, 0)[k] == Approx(pos(a, j)[k] - pos(a, 0)[k]).margin(1e-4));
    CHECK(pos(b, 0)[0] == Approx(0.0f).margin(1e-5));
    CHECK(pos(b, 0)[1] == Approx(0.0f).margin(1e-5));
    CHECK(pos(b, 0)[2] == Approx(static_cast<float>(f)).margin(1e-5));
  }
  RetargetMap none;
  none.pairs = {{"Nope", "Nada"}};
  CHECK_THROWS_WITH(retarget(m, m.skeleton, mat4_identity(), none), Contains("no joint of the motion maps"));
}

TEST_CASE("retargeting moves legs that hang off a root above the hips along with the hips", "[character][retarget]") {
  // Quaternius rigs: Root -> Hips -> Spine and Root -> LeftUpLeg -> LeftLeg.
  // The root motion must carry the legs too, not stretch the pelvis.
  const char* target_bvh = R"(HIERARCHY
ROOT Root
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Hips
  {
    OFFSET 0 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT Spine
    {
      OFFSET 0 2 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 3 0
      }
    }
  }
  JOINT LeftUpLeg
  {
    OFFSET 1 -1 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT LeftLeg
    {
      OFFSET 0 -4 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 -4 0
      }
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.0333333
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
)";
  const Motion m = load_bvh(charfix::write_temp("self.bvh", kBvh));
  const Motion t = load_bvh(charfix::write_temp("rooted.bvh", target_bvh));
  RetargetMap map;
  for (const auto& n : m.skeleton.names) map.pairs.push_back({n, n});
  const Clip c = retarget(m, t.skeleton, mat4_identity(), map);
  REQUIRE(c.frames.size() == m.clip.frames.size());
  const std::int32_t sh = m.skeleton.find("Hips"), th = t.skeleton.find("Hips");
  for (std::size_t f = 0; f < c.frames.size(); ++f) {
    const auto a = global_transforms(m.skeleton, m.clip.frames[f]), b = global_transforms(t.skeleton, c.frames[f]);
    CHECK(pos(b, th)[2] == Approx(static_cast<float>(f)).margin(1e-5));  // the walk moves 1 per frame
    for (const char* name : {"LeftUpLeg", "LeftLeg", "Spine"}) {
      const std::int32_t sj = m.skeleton.find(name), tj = t.skeleton.find(name);
      for (int k = 0; k < 3; ++k)
        CHECK(pos(b, tj)[k] - pos(b, th)[k] == Approx(pos(a, sj)[k] - pos(a, sh)[k]).margin(1e-4));
    }
  }
}

TEST_CASE("the procedural swing motion imports as a CMU-named BVH and retargets", "[character][bvh][procedural]") {
  const Motion m = load_bvh(charfix::write_temp("swing.bvh", procedural_swing_bvh()));
  CHECK(m.skeleton.num_joints() == 20);
  REQUIRE(m.clip.frames.size() == 24);
  CHECK(m.clip.fps == Approx(30.0f).epsilon(1e-3));
  for (const char* name : {"Hips", "LeftUpLeg", "RightForeArm", "Head"}) CHECK(m.skeleton.find(name) >= 0);
  const std::int32_t hips = m.skeleton.find("Hips");
  // The hips move 0.6 per frame and bob between 15.5 and 15.8.
  CHECK(pos(global_transforms(m.skeleton, m.clip.frames[12]), hips)[2] == Approx(7.2f).margin(1e-4));
  CHECK(pos(global_transforms(m.skeleton, m.clip.frames[6]), hips)[1] == Approx(15.8f).margin(1e-4));
  CHECK(load_bvh(charfix::write_temp("swing5.bvh", procedural_swing_bvh(5))).clip.frames.size() == 5);
  CHECK_THROWS(procedural_swing_bvh(0));
  // The default map drives a humanoid with it.
  const Character ch = procedural_character();
  CHECK(retarget(m, ch.skeleton, mat4_identity()).frames.size() == 24);
}

TEST_CASE("random poses: deterministic per seed, within limits, roots at rest", "[character][pose]") {
  const Character ch = charfix::tube_character();
  const Pose rest = rest_pose(ch.skeleton);
  const auto limits = uniform_limits(ch.skeleton, 0.4f);
  std::mt19937 a(11), b(11), c(12);
  const Pose pa = random_pose(ch.skeleton, rest, limits, a), pb = random_pose(ch.skeleton, rest, limits, b),
             pc = random_pose(ch.skeleton, rest, limits, c);
  CHECK(pa.local[1].rotation == pb.local[1].rotation);
  CHECK(pa.local[1].rotation != pc.local[1].rotation);
  CHECK(pa.local[0].rotation == rest.local[0].rotation);
  for (int i = 0; i < 200; ++i) {
    const Pose p = random_pose(ch.skeleton, rest, limits, c);
    const float w = std::abs(p.local[1].rotation[3]);
    CHECK(2.0f * std::acos(std::min(w, 1.0f)) <= std::sqrt(3.0f) * 0.4f + 1e-4f);
  }
  auto bad = limits;
  bad[1].lo[0] = 1.0f;
  CHECK_THROWS(random_pose(ch.skeleton, rest, bad, c));
}

TEST_CASE("CMU motions import; a retargeted walk keeps a humanoid's feet on the ground", "[character][retarget][data]") {
  const auto dir = charfix::data_dir();
  const auto walk = dir / "motion" / "cmu" / "walk.bvh";
  const auto farmer = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  if (dir.empty() || !std::filesystem::exists(walk) || !std::filesystem::exists(farmer)) {
    WARN("SKIPPED: data not found (" << walk << ", " << farmer << ")");
    return;
  }
  const Motion m = load_bvh(walk.string());
  CHECK(m.skeleton.num_joints() == 31);
  CHECK(m.clip.frames.size() == 344);
  CHECK(m.clip.fps == Approx(120.0f).epsilon(1e-3));
  const Character ch = load_gltf(farmer.string());
  const NormalisationStats st = compute_normalisation(ch);
  const Clip c = retarget(m, ch.skeleton, st.bind_to_world);
  REQUIRE(c.frames.size() == 344);
  // World rest mesh: its lowest point is the ground.
  const auto rest = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, world_bind_pose(ch.skeleton, st.bind_to_world)));
  float ground = 1e30f, top = -1e30f;
  for (std::size_t v = 0; v < rest.size() / 3; ++v) {
    ground = std::min(ground, rest[3 * v + 1]);
    top = std::max(top, rest[3 * v + 1]);
  }
  const float height = top - ground;
  REQUIRE(height > 0.0f);
  for (std::size_t f = 0; f < c.frames.size(); f += 20) {
    const auto p = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, c.frames[f]));
    float lo = 1e30f, hi = -1e30f;
    for (std::size_t v = 0; v < p.size() / 3; ++v) {
      lo = std::min(lo, p[3 * v + 1]);
      hi = std::max(hi, p[3 * v + 1]);
    }
    INFO("frame " << f << ": lowest " << lo << ", ground " << ground << ", height " << height);
    CHECK(lo > ground - 0.05f * height);  // feet do not sink into the ground
    CHECK(lo < ground + 0.10f * height);  // and one foot stays near it
    CHECK(hi - lo > 0.8f * height);       // upright
  }
}

TEST_CASE("BVH: a joint's name is the rest of its line (3ds Max Biped's spaces kept)", "[character][bvh]") {
  const std::string text =
      "HIERARCHY\nROOT Bip01 Pelvis\n{\n  OFFSET 0 1 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
      "Yrotation\n  JOINT Bip01 L Thigh  {\n    OFFSET 0.1 0 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
      "    End Site\n    {\n      OFFSET 0 -0.4 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n"
      "0 1 0 0 0 0 0 0 0\n";
  const gatcore::character::Motion m = gatcore::character::parse_bvh(text, "biped.bvh");
  REQUIRE(m.skeleton.num_joints() == 2);
  CHECK(m.skeleton.names[0] == "Bip01 Pelvis");
  CHECK(m.skeleton.names[1] == "Bip01 L Thigh");
  // A ROOT / JOINT without a name on its line is refused, naming the line.
  CHECK_THROWS_WITH(gatcore::character::parse_bvh("HIERARCHY\nROOT\n{\n", "bad.bvh"),
                    Catch::Contains("bad.bvh: line 2") && Catch::Contains("joint name"));
}
