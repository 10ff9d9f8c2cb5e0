// File targets (character/target_frames.hpp) and the reference-deformer
// interface: what gat deform writes (morph-target glTF, .pc2) and a .pc2 from
// another deformer (one cache per primitive) read back as per-frame target
// meshes, frame map and errors.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "character_fixtures.hpp"
#include "gatcore/character/bake.hpp"
#include "gatcore/character/deform.hpp"
#include "gatcore/character/gltf.hpp"
#include "gatcore/character/motion.hpp"
#include "gatcore/character/procedural.hpp"
#include "gatcore/character/reference_deformer.hpp"
#include "gatcore/character/target_frames.hpp"
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

// A synthetic nonlinear deformer: LBS pushed along the LBS normal by an
// amount that depends on the posed height (a bulge that moves with the pose).
std::vector<float> bulge(const Character& ch, const Pose& pose) {
  std::vector<float> p = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, pose));
  const std::vector<float> n = vertex_normals(p, ch.mesh.triangles);
  for (std::size_t v = 0; v < p.size() / 3; ++v) {
    const float a = 0.02f * std::sin(6.0f * p[3 * v + 1]) * std::cos(4.0f * p[3 * v]);
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
