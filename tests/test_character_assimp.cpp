// FBX import through assimp. The FBX files are made here: the generated glTF
// (and, with the shared data, CesiumMan) converted to ASCII FBX with
// assimp's exporter (its binary FBX writer's output is not re-readable by
// assimp 5.2), then compared with the glTF import of the same character.
#include <catch2/catch.hpp>

#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <map>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

std::string to_fbx(const std::string& src, const std::string& name) {
  Assimp::Importer imp;
  const aiScene* s = imp.ReadFile(src, 0);
  REQUIRE(s != nullptr);
  const auto out = (std::filesystem::temp_directory_path() / "gatcore_char_tests" / name).string();
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
