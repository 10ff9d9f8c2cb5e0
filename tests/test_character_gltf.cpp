// glTF import: a generated skinned .glb (always), the bad-file cases, and the
// real characters in ../shared/data (skipped visibly when absent).
#include <catch2/catch.hpp>

#include <limits>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/target_frames.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

float extent(const std::vector<float>& p) {
  float lo[3], hi[3];
  for (int c = 0; c < 3; ++c) lo[c] = hi[c] = p[c];
  for (std::size_t i = 0; i < p.size(); ++i) {
    lo[i % 3] = std::min(lo[i % 3], p[i]);
    hi[i % 3] = std::max(hi[i % 3], p[i]);
  }
  return std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
}

}  // namespace

TEST_CASE("glTF import of a generated skinned character", "[character][gltf]") {
  const std::string path = charfix::write_temp("tube.glb", charfix::skinned_glb());
  const Character ch = load_gltf(path);
  // 6 rings x (8 + 1 seam) file vertices + an 8-vertex box; the seam welds away.
  CHECK(ch.num_file_vertices() == 6 * 9 + 8);
  CHECK(ch.mesh.num_vertices() == 6 * 8 + 8);
  CHECK(ch.mesh.num_triangles() == 5 * 8 * 2 + 12);
  CHECK(ch.primitives.size() == 2);
  REQUIRE(ch.skeleton.num_joints() == 3);
  CHECK(ch.skeleton.names == std::vector<std::string>{"root", "bone1", "helper"});
  CHECK(ch.skeleton.parents == std::vector<std::int32_t>{-1, 0, 1});
  // The helper joint has no weight but stays in the skeleton.
  for (std::int32_t j : ch.mesh.weights.joint) CHECK(j != 2);
  // Two disjoint components (tube, box).
  CHECK(connected_components(ch.mesh).count == 2);
  // Weights renormalised (the file's sum to 0.9).
  ch.mesh.validate(3);
  // The weld map points every file vertex at a welded vertex at the same place.
  const charfix::Tube t = charfix::tube_geometry(6, 8, 2.0f, 0.25f, true, false);
  for (std::int64_t v = 0; v < 6 * 9; ++v)
    for (int c = 0; c < 3; ++c) CHECK(ch.mesh.positions[3 * ch.welded_from_file[v] + c] == Approx(t.pos[3 * v + c]));
  CHECK(ch.welded_from_file[8] == ch.welded_from_file[0]);  // the seam column
  // Clip sampled at 30 fps over one second.
  REQUIRE(ch.clips.size() == 1);
  CHECK(ch.clips[0].name == "bend");
  CHECK(ch.clips[0].frames.size() == 31);
  const Quat q = ch.clips[0].frames[15].local[1].rotation;  // halfway: 45 degrees about x
  CHECK(q[0] == Approx(std::sin(3.14159265f / 8)).margin(1e-5));
  // Skinning the bind pose (and the file's rest pose, identical here) gives the mesh back.
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bind_pose(ch.skeleton))),
                     ch.mesh.positions) < 1e-5f);
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, rest_pose(ch.skeleton))),
                     ch.mesh.positions) < 1e-5f);
}

TEST_CASE("glTF import rejects bad files with the file and the problem", "[character][gltf]") {
  const std::string good = charfix::skinned_glb();
  SECTION("missing file") {
    CHECK_THROWS_WITH(load_gltf("/nonexistent/dir/x.glb"), Contains("/nonexistent/dir/x.glb") && Contains("cannot open"));
  }
  SECTION("truncated") {
    const std::string p = charfix::write_temp("truncated.glb", good.substr(0, good.size() / 2));
    CHECK_THROWS_AS(load_gltf(p), gatcore::InvalidArgument);
    CHECK_THROWS_WITH(load_gltf(p), Contains("truncated.glb"));
  }
  SECTION("wrong magic") {
    std::string bad = good;
    bad[0] = 'X';
    const std::string p = charfix::write_temp("magic.glb", bad);
    CHECK_THROWS_WITH(load_gltf(p), Contains("magic.glb") && Contains("not a readable glTF"));
  }
  SECTION("missing skin") {
    charfix::GlbOptions o;
    o.skin = false;
    const std::string p = charfix::write_temp("noskin.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("noskin.glb") && Contains("no skin"));
  }
  SECTION("weights on a missing joint") {
    charfix::GlbOptions o;
    o.bad_joint = 7;
    const std::string p = charfix::write_temp("badjoint.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("badjoint.glb") && Contains("joint 7") && Contains("only 3 joints"));
  }
  SECTION("NaN position") {
    charfix::GlbOptions o;
    o.nan = true;
    const std::string p = charfix::write_temp("nan.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("nan.glb") && Contains("POSITION") && Contains("not finite"));
  }
  SECTION("garbage json") {
    const std::string p = charfix::write_temp("garbage.gltf", "{\"asset\": {\"version\": \"2.0\"");
    CHECK_THROWS_WITH(load_gltf(p), Contains("garbage.gltf"));
  }
  SECTION("singular inverse bind matrices") {
    charfix::GlbOptions o;
    o.zero_ibm = true;
    const std::string p = charfix::write_temp("zero_ibm.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("zero_ibm.glb") && Contains("inverse bind matrix 0") &&
                                        Contains("is not invertible"));
  }
  SECTION("a singular matrix in a mesh's own skin, for joints another skin also binds") {
    // Every skin's matrices map its meshes into the bind space: none may be
    // singular, not only the first one seen per joint.
    charfix::GlbOptions o;
    o.split_skin = true;
    o.split_skin_scale = 0.0f;
    const std::string p = charfix::write_temp("split_skin_zero.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("split_skin_zero.glb") && Contains("skin 0 inverse bind matrix 0") &&
                                        Contains("(joint 'bone1') is not invertible"));
  }
  SECTION("animation key times out of order, not finite, or years long") {
    // Found by fuzz_gltf: times of 1e31 s made the importer cast 1e32 frames
    // to int (undefined) and would have sampled the clip for ever.
    charfix::GlbOptions o;
    o.key_times[0] = 1.0f;
    o.key_times[1] = 0.5f;
    std::string p = charfix::write_temp("anim_order.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("anim_order.glb") && Contains("animation 'bend' sampler 0 input") &&
                                        Contains("key time 1 is 0.5 after 1"));
    o.key_times[0] = -1.0f;
    p = charfix::write_temp("anim_negative.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("anim_negative.glb") && Contains("key time 0 is -1"));
    o.key_times[0] = 0.0f;
    o.key_times[1] = std::numeric_limits<float>::quiet_NaN();
    p = charfix::write_temp("anim_nan.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("anim_nan.glb") && Contains("input: element 1 is not finite"));
    o.key_times[1] = 1e9f;  // 32 years at 30 fps
    p = charfix::write_temp("anim_years.glb", charfix::skinned_glb(o));
    CHECK_THROWS_WITH(load_gltf(p), Contains("anim_years.glb") && Contains("animation 'bend' lasts 1e+09 s") &&
                                        Contains("joint samples a clip may hold"));
    // Without clips the file loads: the mesh and rig are fine.
    GltfImportOptions no_clips;
    no_clips.load_clips = false;
    CHECK(load_gltf(p, no_clips).clips.empty());
    // A clip of 10 minutes is sampled.
    o.key_times[1] = 600.0f;
    p = charfix::write_temp("anim_long.glb", charfix::skinned_glb(o));
    const Character c = load_gltf(p);
    REQUIRE(c.clips.size() == 1);
    CHECK(c.clips[0].frames.size() == 18001);
  }
}

TEST_CASE("glTF import reads external URIs only inside the model's folder", "[character][gltf]") {
  namespace fs = std::filesystem;
  const fs::path top = fs::temp_directory_path() / "gatcore_uri_test", dir = top / "model";
  fs::create_directories(dir);
  std::ofstream(top / "secret.bin", std::ios::binary) << "0123456789abcdef";
  std::ofstream(dir / "inside.bin", std::ios::binary) << "0123456789abcdef";
  auto gltf = [&](const std::string& name, const std::string& uri) {
    const fs::path p = dir / name;
    std::ofstream(p) << "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":16,\"uri\":\"" << uri << "\"}]}";
    return p.string();
  };
  for (const std::string& uri : std::vector<std::string>{"../secret.bin", "../../gatcore_uri_test/secret.bin", "./../secret.bin"}) {
    INFO(uri);
    CHECK_THROWS_WITH(load_gltf(gltf("escape.gltf", uri)),
                      Contains("escape.gltf") && Contains("refusing to read") && Contains("outside the model's folder"));
  }
  // An absolute URI is joined to the folder by tinygltf, so it names no file there.
  CHECK_THROWS_WITH(load_gltf(gltf("abs.gltf", (top / "secret.bin").string())), Contains("abs.gltf") && Contains("not found"));
  // A symlink inside the folder that points out of it is refused too.
  fs::remove(dir / "link.bin");
  fs::create_symlink(top / "secret.bin", dir / "link.bin");
  CHECK_THROWS_WITH(load_gltf(gltf("link.gltf", "link.bin")), Contains("outside the model's folder"));
  // Inside: read (the file then fails later, for having no skin).
  CHECK_THROWS_WITH(load_gltf(gltf("inside.gltf", "inside.bin")), !Contains("refusing") && Contains("no skin"));
  // An option widens the folder.
  GltfImportOptions wide;
  wide.resource_root = top.string();
  CHECK_THROWS_WITH(load_gltf(gltf("escape.gltf", "../secret.bin"), wide), !Contains("refusing") && Contains("no skin"));
  // The other glTF reader (gltf_util::read_model: a user's file re-read by
  // deform / predict-weights exports and morph-target frames) is confined too.
  CHECK_THROWS_WITH(read_morph_target_frames(charfix::tube_character(), gltf("escape.gltf", "../secret.bin")),
                    Contains("escape.gltf") && Contains("refusing to read") && Contains("outside the model's folder"));

}

namespace {
struct Expected {
  const char* file;
  std::int64_t file_vertices, vertices;
  std::int32_t joints;
};
}  // namespace

TEST_CASE("glTF import of the shared real characters", "[character][gltf][data]") {
  const auto dir = charfix::data_dir();
  if (dir.empty()) {
    WARN("SKIPPED: data not found (../shared/data or $GATCORE_DATA)");
    return;
  }
  namespace fs = std::filesystem;
  // Counts measured on the shared files: file vertices, welded vertices, joints.
  const Expected expected[] = {
      {"characters/khronos/CesiumMan.glb", 3273, 2338, 19},
      {"characters/khronos/RiggedFigure.glb", 370, 130, 19},
      {"characters/khronos/RiggedSimple.glb", 96, 96, 2},
  };
  for (const auto& e : expected) {
    const fs::path p = dir / e.file;
    if (!fs::exists(p)) {
      WARN("SKIPPED: data not found: " << p);
      continue;
    }
    INFO(p);
    const Character ch = load_gltf(p.string());
    CHECK(ch.num_file_vertices() == e.file_vertices);
    CHECK(ch.mesh.num_vertices() == e.vertices);
    CHECK(ch.skeleton.num_joints() == e.joints);
    const auto lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bind_pose(ch.skeleton)));
    CHECK(max_abs_diff(lbs, ch.mesh.positions) < 1e-4f * extent(ch.mesh.positions));
  }
  // Every Quaternius character loads; the humanoids have the README's joint counts.
  int loaded = 0;
  for (const char* sub : {"modular_men", "modular_women", "animals", "creatures"}) {
    const fs::path d = dir / "characters" / "quaternius" / sub;
    if (!fs::is_directory(d)) {
      WARN("SKIPPED: data not found: " << d);
      continue;
    }
    for (const auto& f : fs::directory_iterator(d)) {
      if (f.path().extension() != ".glb") continue;
      INFO(f.path());
      if (std::string(sub) == "modular_women" && f.path().filename() == "Adventurer.glb") {
        // A genuinely broken file: the legs' WEIGHTS_0 are NaN (1860 vertices).
        CHECK_THROWS_WITH(load_gltf(f.path().string()),
                          Contains("Adventurer.glb") && Contains("Adventurer_Legs") && Contains("not finite"));
        continue;
      }
      GltfImportOptions opt;
      opt.load_clips = std::string(sub) == "animals";  // keep the test fast: clips of one pack
      const Character ch = load_gltf(f.path().string(), opt);
      ++loaded;
      CHECK(ch.mesh.num_vertices() > 0);
      CHECK(ch.mesh.num_vertices() <= ch.num_file_vertices());
      if (std::string(sub) == "modular_men") CHECK(ch.skeleton.num_joints() == 49);
      if (std::string(sub) == "modular_women") CHECK(ch.skeleton.num_joints() == 51);
      if (std::string(sub) == "animals") CHECK(!ch.clips.empty());
      const auto lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bind_pose(ch.skeleton)));
      CHECK(max_abs_diff(lbs, ch.mesh.positions) < 1e-4f * extent(ch.mesh.positions));
    }
  }
  CHECK(loaded > 0);
}

TEST_CASE("glTF export of new weights re-imports with those weights, the rest intact", "[character][gltf][export]") {
  const std::string src = charfix::write_temp("export_src.glb", charfix::skinned_glb());
  const Character ch = load_gltf(src);
  // New weights: the box goes to the (weightless) helper joint, the tube keeps its own.
  SkinWeights w = ch.mesh.weights;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v)
    if (ch.mesh.positions[3 * v] >= 0.5f - 1e-6f) {  // box vertices (x in [0.5, 0.6])
      REQUIRE(w.ptr[v + 1] - w.ptr[v] == 1);
      w.joint[w.ptr[v]] = 2;
    }
  for (const char* name : {"export_out.glb", "export_out.gltf"}) {
    const auto out = (charfix::temp_dir() / name).string();
    save_gltf_with_weights(src, ch, w, out);
    const Character back = load_gltf(out);
    INFO(out);
    REQUIRE(back.mesh.num_vertices() == ch.mesh.num_vertices());
    CHECK(back.mesh.positions == ch.mesh.positions);
    CHECK(back.mesh.triangles == ch.mesh.triangles);
    CHECK(back.skeleton.names == ch.skeleton.names);
    CHECK(back.clips.size() == 1);
    CHECK(back.mesh.weights.joint == w.joint);
    REQUIRE(back.mesh.weights.weight.size() == w.weight.size());
    for (std::size_t k = 0; k < w.weight.size(); ++k) CHECK(back.mesh.weights.weight[k] == Approx(w.weight[k]).margin(1e-6));
    CHECK(max_abs_diff(linear_blend_skinning(back.mesh, skinning_matrices(back.skeleton, bind_pose(back.skeleton))),
                       back.mesh.positions) < 1e-5f);
  }
  SkinWeights wrong;
  CHECK_THROWS_WITH(save_gltf_with_weights(src, ch, wrong, "/tmp/x.glb"), Contains("weight rows"));
}

TEST_CASE("glTF import of one skin per mesh, each relative to its own mesh, in one bind space",
          "[character][gltf][export]") {
  // The same tube and box as the one-skin file, but the box on its own node
  // with its own skin (listed first), stored in its own space and bound by
  // matrices relative to it: the first skin's matrices must not place the
  // tube, nor the tube's the box.
  charfix::GlbOptions so;
  so.split_skin = true;
  const std::string src = charfix::write_temp("split_skin.glb", charfix::skinned_glb(so));
  const Character one = load_gltf(charfix::write_temp("one_skin.glb", charfix::skinned_glb()));
  const Character ch = load_gltf(src);
  REQUIRE(ch.mesh.num_vertices() == one.mesh.num_vertices());
  CHECK(max_abs_diff(ch.mesh.positions, one.mesh.positions) < 1e-5f);
  CHECK(ch.mesh.triangles == one.mesh.triangles);
  CHECK(ch.mesh.weights.joint == one.mesh.weights.joint);
  REQUIRE(ch.skeleton.num_joints() == 3);
  for (int j = 0; j < 3; ++j)
    for (int e = 0; e < 16; ++e) CHECK(ch.skeleton.inverse_bind[j][e] == Approx(one.skeleton.inverse_bind[j][e]).margin(1e-6));
  // The reference is the skin binding the most vertices (the tube's): its
  // primitive needs no map, the box's is box_to_bind().
  REQUIRE(ch.primitives.size() == 2);
  CHECK(ch.primitives[0].to_bind == mat4_identity());
  for (int e = 0; e < 16; ++e) CHECK(ch.primitives[1].to_bind[e] == Approx(charfix::box_to_bind()[e]).margin(1e-6));
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bind_pose(ch.skeleton))),
                     ch.mesh.positions) < 1e-5f);

  SECTION("new weights on a joint the box's skin lacks: its matrix is written in the box's space") {
    SkinWeights w;
    w.ptr = {0};
    for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
      const bool box = ch.mesh.positions[3 * v] >= 0.5f - 1e-5f;
      for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k)
        if (!box) w.joint.push_back(ch.mesh.weights.joint[k]), w.weight.push_back(ch.mesh.weights.weight[k]);
      if (box) w.joint.insert(w.joint.end(), {1, 2}), w.weight.insert(w.weight.end(), {0.5f, 0.5f});  // helper: new to it
      w.ptr.push_back(static_cast<std::int64_t>(w.joint.size()));
    }
    const auto out = (charfix::temp_dir() / "split_skin_out.glb").string();
    save_gltf_with_weights(src, ch, w, out);
    const Character back = load_gltf(out);
    REQUIRE(back.mesh.num_vertices() == ch.mesh.num_vertices());
    CHECK(max_abs_diff(back.mesh.positions, ch.mesh.positions) < 1e-5f);
    CHECK(back.mesh.weights.joint == w.joint);
    for (int j = 0; j < 3; ++j)
      for (int e = 0; e < 16; ++e)
        CHECK(back.skeleton.inverse_bind[j][e] == Approx(ch.skeleton.inverse_bind[j][e]).margin(1e-6));
  }
  SECTION("morph-target frames go back through the box's map and read back") {
    BakedFrames baked;
    baked.fps = 10.0f;
    for (int f = 0; f < 3; ++f) {
      std::vector<float> p = ch.mesh.positions;
      for (std::size_t i = 0; i < p.size(); ++i) p[i] += 0.01f * float(f + 1) * float(1 + i % 3);
      baked.positions.push_back(p);
    }
    const auto glb = (charfix::temp_dir() / "split_skin_baked.glb").string();
    save_gltf_morph_animation(src, ch, baked, glb);
    for (const Character& c : {ch, load_gltf(glb)}) {
      const TargetFrames t = read_target_frames(c, glb);
      REQUIRE(t.positions.size() == baked.positions.size());
      for (std::size_t f = 0; f < t.positions.size(); ++f) CHECK(max_abs_diff(t.positions[f], baked.positions[f]) < 1e-5f);
    }
  }
}

TEST_CASE("glTF export keeps a real character's content", "[character][gltf][export][data]") {
  const auto dir = charfix::data_dir();
  const auto p = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  if (dir.empty() || !std::filesystem::exists(p)) {
    WARN("SKIPPED: data not found (" << p << ")");
    return;
  }
  const Character ch = load_gltf(p.string());
  const auto out = (charfix::temp_dir() / "Farmer_weights.glb").string();
  save_gltf_with_weights(p.string(), ch, ch.mesh.weights, out);
  const Character back = load_gltf(out);
  CHECK(back.mesh.positions == ch.mesh.positions);
  CHECK(back.mesh.weights.joint == ch.mesh.weights.joint);
  for (std::size_t k = 0; k < ch.mesh.weights.weight.size(); ++k)
    CHECK(back.mesh.weights.weight[k] == Approx(ch.mesh.weights.weight[k]).margin(1e-5));
  // Materials, images and names survive (occurrences of their JSON keys).
  auto count = [](const std::string& file, const char* key) {
    std::ifstream f(file, std::ios::binary);
    const std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::size_t n = 0;
    for (std::size_t at = s.find(key); at != std::string::npos; at = s.find(key, at + 1)) ++n;
    return n;
  };
  for (const char* key : {"\"materials\"", "\"material\"", "\"mimeType\"", "\"name\""})
    CHECK(count(out, key) == count(p.string(), key));
}
