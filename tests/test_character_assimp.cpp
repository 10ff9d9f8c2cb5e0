// FBX import through assimp. The FBX files are made here: the generated glTF
// (and, with the shared data, CesiumMan) converted to ASCII FBX with
// assimp's exporter (its binary FBX writer's output is not re-readable by
// assimp 5.2), then compared with the glTF import of the same character.
#include <catch2/catch.hpp>

#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/scene.h>
#include <pthread.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <csignal>
#include <cmath>
#include <filesystem>
#include <map>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

std::string to_fbx(const std::string& src, const std::string& name) {
  Assimp::Importer imp;
  const aiScene* s = imp.ReadFile(src, 0);
  REQUIRE(s != nullptr);
  const auto out = (charfix::temp_dir() / name).string();
  Assimp::Exporter ex;
  REQUIRE(ex.Export(s, "fbxa", out) == AI_SUCCESS);
  return out;
}

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// Weights by (rounded position, joint name): comparable across importers.
std::map<std::pair<std::array<long, 3>, std::string>, float> weights_by_position(const Character& ch) {
  std::map<std::pair<std::array<long, 3>, std::string>, float> m;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    std::array<long, 3> key;
    for (int c = 0; c < 3; ++c) key[c] = std::lround(ch.mesh.positions[3 * v + c] * 1e4);
    for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k)
      m[{key, ch.skeleton.names[ch.mesh.weights.joint[k]]}] += ch.mesh.weights.weight[k];
  }
  return m;
}

}  // namespace

TEST_CASE("FBX import matches the glTF import of the same character", "[character][fbx]") {
  const std::string glb = charfix::write_temp("fbx_src.glb", charfix::skinned_glb());
  const std::string fbx = to_fbx(glb, "tube.fbx");
  const Character a = load_gltf(glb), b = load_character(fbx);
  CHECK(b.mesh.num_vertices() == a.mesh.num_vertices());
  CHECK(b.mesh.num_triangles() == a.mesh.num_triangles());
  CHECK(connected_components(b.mesh).count == 2);
  CHECK(b.skeleton.find("root") >= 0);
  CHECK(b.skeleton.find("bone1") >= 0);
  CHECK(max_abs_diff(linear_blend_skinning(b.mesh, skinning_matrices(b.skeleton, bind_pose(b.skeleton))),
                     b.mesh.positions) < 1e-4f);
  const auto wa = weights_by_position(a), wb = weights_by_position(b);
  REQUIRE(wa.size() == wb.size());
  for (const auto& [k, w] : wa) {
    REQUIRE(wb.count(k) == 1);
    CHECK(wb.at(k) == Approx(w).margin(1e-4));
  }
  REQUIRE(b.clips.size() == 1);
  CHECK(b.clips[0].frames.size() == 31);
}

TEST_CASE("FBX import rejects bad files", "[character][fbx]") {
  CHECK_THROWS_WITH(load_character("/nonexistent/x.fbx"), Contains("/nonexistent/x.fbx") && Contains("cannot open"));
  const std::string g = charfix::write_temp("garbage.fbx", "; FBX 7.4.0 project file\nnot really\n");
  CHECK_THROWS_AS(load_character(g), gatcore::InvalidArgument);
  CHECK_THROWS_WITH(load_character(g), Contains("garbage.fbx"));
  charfix::GlbOptions o;
  o.skin = false;
  const std::string fbx = to_fbx(charfix::write_temp("fbx_noskin.glb", charfix::skinned_glb(o)), "noskin.fbx");
  CHECK_THROWS_WITH(load_character(fbx), Contains("noskin.fbx") && Contains("no skin"));
  // assimp parses a user's file in a child process first; its refusal comes back with its message.
  CHECK_THROWS_WITH(load_character(g), Contains("garbage.fbx: not a readable character file: "));
  // BVH never reaches assimp (its BVH importer corrupts memory on bad files).
  const std::string bvh = charfix::write_temp("uaf.bvh", "HIERARCHY\nROOT a\n{JOINT b\n{CHANNELS 1 Xrotation}}\n");
  CHECK_THROWS_WITH(load_character(bvh), Contains("uaf.bvh: a BVH file holds a motion, not a character"));
}

namespace {
// Observes the forks of load_character's containment:
// pthread_atfork's handlers run in this process before each fork and in the
// child after it. When `crash_child` is set the child dies of SIGSEGV before
// it parses, standing in for a file that crashes assimp's importer.
std::atomic<int> forks{0};
std::atomic<bool> crash_child{false};
void count_fork() { ++forks; }
void child_after_fork() {
  if (crash_child) {
    std::signal(SIGSEGV, SIG_DFL);  // not Catch2's handler: the child just dies
    ::raise(SIGSEGV);
  }

}
}  // namespace

TEST_CASE("assimp parses a user's file in a child process: a crash there refuses the file", "[character][fbx]") {
  static const int registered = pthread_atfork(&count_fork, nullptr, &child_after_fork);
  REQUIRE(registered == 0);
  const std::string fbx = to_fbx(charfix::write_temp("fbx_probe.glb", charfix::skinned_glb()), "probe.fbx");
  forks = 0;
  CHECK_NOTHROW(load_character(fbx));
  CHECK(forks == 1);  // parsed in a child first, then here
  crash_child = true;
  CHECK_THROWS_WITH(load_character(fbx), Contains("probe.fbx: the assimp importer failed on this file (signal " +
                                                  std::to_string(SIGSEGV) + ")"));
  crash_child = false;
  CHECK(forks == 2);
  CHECK_NOTHROW(load_character(fbx));  // this process is unharmed
}

TEST_CASE("FBX import of CesiumMan", "[character][fbx][data]") {

  const auto dir = charfix::data_dir();
  const auto p = dir / "characters" / "khronos" / "CesiumMan.glb";
  if (dir.empty() || !std::filesystem::exists(p)) {
    WARN("SKIPPED: data not found (" << p << ")");
    return;
  }
  const Character a = load_gltf(p.string()), b = load_character(to_fbx(p.string(), "CesiumMan.fbx"));
  CHECK(b.mesh.num_vertices() == a.mesh.num_vertices());
  CHECK(b.skeleton.num_joints() == a.skeleton.num_joints());
  CHECK(max_abs_diff(linear_blend_skinning(b.mesh, skinning_matrices(b.skeleton, bind_pose(b.skeleton))),
                     b.mesh.positions) < 1e-3f);
}

// ---------------------------------------------------------------------------
// gatcore's own BVH reader gives the same joint transforms as the assimp
// import it replaced (assimp's BVH importer corrupts memory on bad
// files, so BVH no longer goes through it). The reference below is the old
// load_bvh, kept here only to compare against, on well-formed files.

namespace {

Mat4 ai_mat4(const aiMatrix4x4& m) {
  return {m.a1, m.b1, m.c1, m.d1, m.a2, m.b2, m.c2, m.d2, m.a3, m.b3, m.c3, m.d3, m.a4, m.b4, m.c4, m.d4};
}

Motion assimp_bvh_reference(const std::string& path) {
  Assimp::Importer imp;
  const aiScene* scene = imp.ReadFile(path, 0);
  REQUIRE(scene);
  const aiAnimation* anim = scene->mAnimations[0];
  std::map<std::string, const aiNodeAnim*> channel;
  for (unsigned c = 0; c < anim->mNumChannels; ++c) channel[anim->mChannels[c]->mNodeName.C_Str()] = anim->mChannels[c];
  Motion m;
  Skeleton& s = m.skeleton;
  std::vector<const aiNodeAnim*> chan;
  struct Item {
    const aiNode* node;
    int parent;
  };
  std::vector<Item> stack{{scene->mRootNode, -1}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    int self = it.parent;
    auto ch = channel.find(it.node->mName.C_Str());
    if (ch != channel.end()) {
      self = s.num_joints();
      s.names.push_back(it.node->mName.C_Str());
      s.parents.push_back(it.parent);
      s.rest_local.push_back(to_transform(ai_mat4(it.node->mTransformation)));
      chan.push_back(ch->second);
    }
    for (unsigned c = it.node->mNumChildren; c-- > 0;) stack.push_back({it.node->mChildren[c], self});
  }
  std::size_t frames = 0;
  for (const aiNodeAnim* c : chan) frames = std::max<std::size_t>({frames, c->mNumPositionKeys, c->mNumRotationKeys});
  m.clip.fps = float(anim->mTicksPerSecond);
  m.clip.frames.resize(frames);
  for (std::size_t f = 0; f < frames; ++f) {
    Pose& p = m.clip.frames[f];
    p.local = s.rest_local;
    for (std::size_t j = 0; j < chan.size(); ++j) {
      const aiNodeAnim* c = chan[j];
      const aiVector3D& v = c->mPositionKeys[std::min<std::size_t>(f, c->mNumPositionKeys - 1)].mValue;
      p.local[j].translation = {v.x, v.y, v.z};
      const aiQuaternion& q = c->mRotationKeys[std::min<std::size_t>(f, c->mNumRotationKeys - 1)].mValue;
      p.local[j].rotation = quat_normalize({q.x, q.y, q.z, q.w});
    }
  }
  return m;
}

void check_same_motion(const std::string& path) {
  INFO(path);
  const Motion ours = load_bvh(path), ref = assimp_bvh_reference(path);
  REQUIRE(ours.skeleton.names == ref.skeleton.names);
  REQUIRE(ours.skeleton.parents == ref.skeleton.parents);
  CHECK(ours.clip.fps == Approx(ref.clip.fps).epsilon(1e-5));
  REQUIRE(ours.clip.frames.size() == ref.clip.frames.size());
  double worst = 0.0;
  for (std::size_t f = 0; f < ours.clip.frames.size(); ++f)
    for (std::size_t j = 0; j < ref.skeleton.names.size(); ++j) {
      const Mat4 a = to_matrix(ours.clip.frames[f].local[j]), b = to_matrix(ref.clip.frames[f].local[j]);
      for (int k = 0; k < 16; ++k) {
        const double scale = k >= 12 ? std::max(1.0, double(std::abs(b[std::size_t(k)]))) : 1.0;
        worst = std::max(worst, std::abs(double(a[std::size_t(k)]) - double(b[std::size_t(k)])) / scale);
      }
    }
  INFO("largest difference of a local joint matrix entry (rotation; translation relative): " << worst);
  CHECK(worst < 2e-5);
}

}  // namespace

TEST_CASE("BVH: gatcore's reader matches the assimp import on generated motions", "[character][bvh]") {
  check_same_motion(charfix::write_temp("swing.bvh", procedural_swing_bvh(48)));
  // Every Euler order, position channels on a child, a joint without channels.
  check_same_motion(charfix::write_temp("orders.bvh", R"(HIERARCHY
ROOT Root
{
  OFFSET 1 2 3
  CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
  JOINT A
  {
    OFFSET 0 1 0
    CHANNELS 3 Yrotation Xrotation Zrotation
    JOINT B
    {
      OFFSET 0.5 0 0
      CHANNELS 6 Zposition Xposition Yposition Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 0 1
      }
    }
  }
  JOINT C
  {
    OFFSET 0 -1 0
    CHANNELS 3 Xrotation Zrotation Yrotation
    End Site
    {
      OFFSET 0 -1 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.04
0.1 0.2 0.3 10 20 30 -45 60 170 1 2 3 -90 45 12 33 -12 271
5 -2 7 -180 90 -90 0 0 0 -1 -2 -3 179 -179 90 -0.5 0.25 1e-3
0 0 0 0 0 0 360 -360 720 0 0 0 0 0 0 15 30 45
)"));
}

TEST_CASE("BVH: gatcore's reader matches the assimp import on CMU motions", "[character][bvh][data]") {
  const std::filesystem::path dir = std::filesystem::path(GATCORE_SOURCE_DIR) / "../shared/data/motion/cmu";
  if (!std::filesystem::exists(dir / "walk.bvh")) {
    WARN("SKIPPED: " << dir.string() << " not present (third-party data)");
    return;
  }
  for (const char* name : {"walk.bvh", "01_01.bvh"}) check_same_motion((dir / name).string());
}
