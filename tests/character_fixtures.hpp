#pragma once
// Characters the character tests build themselves, so the suite covers the
// importer and the deformers without downloaded data:
// - tube_character(): the library's two-bone tube (character/data/tube.hpp),
//   capped, root at y = 0, "bone1" at y = length / 2, weights blended
//   across the middle;
// - skinned_glb(): the same tube written as a binary glTF by hand, with a UV
//   seam (duplicated vertices), a second primitive (a disjoint box on bone1),
//   a weightless helper joint, an animation, and switches that break it.
// - data_dir(): $GATCORE_DATA when set, else ../shared/data; empty when absent.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gatcore/character/data/tube.hpp"
#include "gatcore/character/rig/character.hpp"

namespace charfix {

inline std::filesystem::path data_dir() {
  namespace fs = std::filesystem;
  if (const char* e = std::getenv("GATCORE_DATA"); e && *e)  // when set, it is the only place looked at
    return fs::is_directory(fs::path(e) / "characters") ? fs::path(e) : fs::path();
  for (fs::path p : {fs::path(GATCORE_SOURCE_DIR) / ".." / "shared" / "data", fs::current_path() / ".." / "shared" / "data"})
    if (fs::is_directory(p / "characters")) return p;
  return {};
}

struct Tube {
  std::vector<float> pos;
  std::vector<std::int32_t> tris;
  std::vector<std::uint16_t> joints;  // 4 per vertex
  std::vector<float> weights;         // 4 per vertex
};

// The library's tube (character/data/tube.hpp), rings x segments, with
// 4 influences per vertex as a glTF file stores them; `seam` duplicates the
// first column as a last one (a UV seam); `caps` adds a centre vertex and a
// fan at each end.
inline Tube tube_geometry(int rings, int segments, float length, float radius, bool seam, bool caps,
                          float blend = 0.3f) {
  gatcore::character::TubeOptions o;
  o.rings = rings, o.segments = segments, o.length = length, o.radius = radius;
  o.seam = seam, o.caps = caps, o.blend = blend;
  const gatcore::character::TubeMesh m = gatcore::character::tube_mesh(o);
  Tube t;
  t.pos = m.positions;
  t.tris = m.triangles;
  const std::size_t ring_vertices = std::size_t(rings) * std::size_t(segments + (seam ? 1 : 0));
  for (std::size_t v = 0; v < m.bone1_weight.size(); ++v) {
    const float w = m.bone1_weight[v];
    if (v < ring_vertices) {
      t.joints.insert(t.joints.end(), {0, 1, 0, 0});
      t.weights.insert(t.weights.end(), {1.0f - w, w, 0.0f, 0.0f});
    } else {  // a cap's centre: all on its end's joint
      t.joints.insert(t.joints.end(), {static_cast<std::uint16_t>(w > 0.5f ? 1 : 0), 0, 0, 0});
      t.weights.insert(t.weights.end(), {1.0f, 0.0f, 0.0f, 0.0f});
    }
  }
  return t;
}

// The capped tube (no seam) as a Character, joints root and bone1.
// `blend`: fraction of the length over which the weights go from root to
// bone1 (0: rigid, a step at the middle).
inline gatcore::character::Character tube_character(int rings = 24, int segments = 24, float length = 2.0f,
                                                    float radius = 0.25f, float blend = 0.3f) {
  gatcore::character::TubeOptions o;
  o.rings = rings, o.segments = segments, o.length = length, o.radius = radius, o.blend = blend;
  o.caps = true;
  return gatcore::character::tube_character(o);
}

struct GlbOptions {
  bool skin = true;          // false: no skin at all
  int bad_joint = -1;        // >= 0: vertex 0 gets weight on this skin joint index
  bool nan = false;          // a NaN position
  bool animation = true;
  float key_times[2] = {0.0f, 1.0f};  // the animation's two key times (s)
  bool second_primitive = true;
  bool zero_ibm = false;     // every inverse bind matrix all zeros (singular)
  // The box on its own node and skin (listed first), stored in its own mesh
  // space: box_to_bind() maps it onto the tube's bind space, and the skin's
  // inverse bind matrices are the tube skin's times that map (as an exporter
  // writing one skin per object does).
  bool split_skin = false;
  float split_skin_scale = 1.0f;  // scales the split skin's matrices' 3x3 part (0: singular)
};

// box space -> bind space of split_skin: rotate 90 degrees about z, scale 2,
// move by (0.3, -0.2, 0.1). Column-major.
inline gatcore::character::Mat4 box_to_bind() {
  return {0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 2, 0, 0.3f, -0.2f, 0.1f, 1};
}

inline void pad4(std::string& s, char c) {
  while (s.size() % 4) s.push_back(c);
}

// The tube (6 rings x 8 segments + seam column) as a .glb.
inline std::string skinned_glb(const GlbOptions& o = {}) {
  Tube t = tube_geometry(6, 8, 2.0f, 0.25f, true, false);
  for (float& w : t.weights) w *= 0.9f;  // not summing to 1: the importer renormalises
  if (o.bad_joint >= 0) {
    t.joints[0] = static_cast<std::uint16_t>(o.bad_joint);
    t.weights[0] = 0.5f;
  }
  if (o.nan) t.pos[4] = std::nanf("");
  // Box on bone1: 8 corners, 12 triangles, weight 1 on joint 1.
  std::vector<float> bpos;
  for (int i = 0; i < 8; ++i) bpos.insert(bpos.end(), {0.5f + 0.1f * (i & 1), 1.5f + 0.1f * ((i >> 1) & 1), 0.1f * (i >> 2)});
  const std::vector<std::uint32_t> btri = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                           2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  std::vector<std::uint16_t> bj;
  std::vector<float> bw;
  for (int i = 0; i < 8; ++i) {
    // The split skin lists bone1 first.
    bj.insert(bj.end(), {static_cast<std::uint16_t>(o.split_skin ? 0 : 1), 0, 0, 0});
    bw.insert(bw.end(), {1.0f, 0.0f, 0.0f, 0.0f});
  }
  if (o.split_skin) {  // into the box's own space: the inverse of box_to_bind()
    for (std::size_t i = 0; i < bpos.size(); i += 3) {
      const float x = bpos[i] - 0.3f, y = bpos[i + 1] + 0.2f, z = bpos[i + 2] - 0.1f;
      bpos[i] = y / 2, bpos[i + 1] = -x / 2, bpos[i + 2] = z / 2;
    }
  }
  std::vector<std::uint32_t> tri(t.tris.begin(), t.tris.end());

  std::string bin;
  std::ostringstream views, accs;
  int nviews = 0;
  auto add = [&](const void* data, std::size_t bytes) {
    pad4(bin, '\0');
    if (nviews) views << ",";
    views << "{\"buffer\":0,\"byteOffset\":" << bin.size() << ",\"byteLength\":" << bytes << "}";
    bin.append(static_cast<const char*>(data), bytes);
    return nviews++;
  };
  int naccs = 0;
  auto acc = [&](int view, int ctype, std::size_t count, const char* type, const std::string& extra = "") {
    if (naccs) accs << ",";
    accs << "{\"bufferView\":" << view << ",\"componentType\":" << ctype << ",\"count\":" << count << ",\"type\":\""
         << type << "\"" << extra << "}";
    return naccs++;
  };
  const std::size_t nv = t.pos.size() / 3;
  const int aP = acc(add(t.pos.data(), t.pos.size() * 4), 5126, nv, "VEC3",
                     ",\"min\":[-0.25,0,-0.25],\"max\":[0.25,2,0.25]");
  const int aJ = acc(add(t.joints.data(), t.joints.size() * 2), 5123, nv, "VEC4");
  const int aW = acc(add(t.weights.data(), t.weights.size() * 4), 5126, nv, "VEC4");
  const int aI = acc(add(tri.data(), tri.size() * 4), 5125, tri.size(), "SCALAR");
  std::ostringstream bbox;  // the accessor's min / max, as glTF wants them
  {
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    for (std::size_t i = 0; i < bpos.size(); ++i) lo[i % 3] = std::min(lo[i % 3], bpos[i]), hi[i % 3] = std::max(hi[i % 3], bpos[i]);
    bbox << ",\"min\":[" << lo[0] << "," << lo[1] << "," << lo[2] << "],\"max\":[" << hi[0] << "," << hi[1] << "," << hi[2] << "]";
  }
  const int bP = acc(add(bpos.data(), bpos.size() * 4), 5126, 8, "VEC3", bbox.str());
  const int bJ = acc(add(bj.data(), bj.size() * 2), 5123, 8, "VEC4");
  const int bW = acc(add(bw.data(), bw.size() * 4), 5126, 8, "VEC4");
  const int bI = acc(add(btri.data(), btri.size() * 4), 5125, btri.size(), "SCALAR");
  // Inverse bind matrices: root at 0, bone1 at y = 1, helper at y = 1.5.
  std::vector<float> ibm;
  for (float y : {0.0f, 1.0f, 1.5f}) ibm.insert(ibm.end(), {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -y, 0, 1});
  if (o.zero_ibm) std::fill(ibm.begin(), ibm.end(), 0.0f);
  const int aIbm = acc(add(ibm.data(), ibm.size() * 4), 5126, 3, "MAT4");
  // Split skin [bone1, root]: the tube's matrices times box_to_bind().
  const gatcore::character::Mat4 x = box_to_bind();
  std::vector<float> bibm(x.begin(), x.end());
  bibm.insert(bibm.end(), x.begin(), x.end());
  bibm[13] -= 1.0f;  // bone1: translate(0, -1, 0) * x
  for (int m = 0; m < 2; ++m)
    for (int e = 0; e < 12; ++e) bibm[16 * m + e] *= o.split_skin_scale;
  const int bIbm = acc(add(bibm.data(), bibm.size() * 4), 5126, 2, "MAT4");
  const std::vector<float> times = {o.key_times[0], o.key_times[1]};
  const float s = std::sin(0.25f * 3.14159265f), c = std::cos(0.25f * 3.14159265f);
  const std::vector<float> rots = {0, 0, 0, 1, s, 0, 0, c};  // 0 -> 90 degrees about x
  const int aT = acc(add(times.data(), 8), 5126, 2, "SCALAR", ",\"min\":[0],\"max\":[1]");
  const int aR = acc(add(rots.data(), 32), 5126, 2, "VEC4");

  std::ostringstream j;
  const bool split = o.split_skin && o.skin && o.second_primitive;
  j << "{\"asset\":{\"version\":\"2.0\",\"generator\":\"gatcore tests\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,3"
    << (split ? ",4" : "") << "]}],";
  j << "\"nodes\":[{\"name\":\"root\",\"children\":[1]},{\"name\":\"bone1\",\"translation\":[0,1,0],\"children\":[2]},"
       "{\"name\":\"helper\",\"translation\":[0,0.5,0]},{\"name\":\"body\",\"mesh\":0"
    << (o.skin ? (split ? ",\"skin\":1" : ",\"skin\":0") : "") << "}"
    << (split ? ",{\"name\":\"box\",\"mesh\":1,\"skin\":0,\"translation\":[5,5,5]}" : "") << "],";
  j << "\"meshes\":[{\"name\":\"tube\",\"primitives\":[{\"attributes\":{\"POSITION\":" << aP << ",\"JOINTS_0\":" << aJ
    << ",\"WEIGHTS_0\":" << aW << "},\"indices\":" << aI << "}";
  if (o.second_primitive)
    j << (split ? "]},{\"name\":\"box\",\"primitives\":[" : ",") << "{\"attributes\":{\"POSITION\":" << bP
      << ",\"JOINTS_0\":" << bJ << ",\"WEIGHTS_0\":" << bW << "},\"indices\":" << bI << "}";
  j << "]}],";
  if (split)
    j << "\"skins\":[{\"joints\":[1,0],\"inverseBindMatrices\":" << bIbm << "},{\"joints\":[0,1,2],\"inverseBindMatrices\":"
      << aIbm << "}],";
  else if (o.skin)
    j << "\"skins\":[{\"joints\":[0,1,2],\"inverseBindMatrices\":" << aIbm << "}],";
  if (o.animation)
    j << "\"animations\":[{\"name\":\"bend\",\"samplers\":[{\"input\":" << aT << ",\"output\":" << aR
      << ",\"interpolation\":\"LINEAR\"}],\"channels\":[{\"sampler\":0,\"target\":{\"node\":1,\"path\":\"rotation\"}}]}],";
  pad4(bin, '\0');
  j << "\"accessors\":[" << accs.str() << "],\"bufferViews\":[" << views.str() << "],\"buffers\":[{\"byteLength\":"
    << bin.size() << "}]}";
  std::string json = j.str();
  pad4(json, ' ');
  std::string glb;
  auto u32 = [&](std::uint32_t x) { glb.append(reinterpret_cast<const char*>(&x), 4); };
  glb += "glTF";
  u32(2);
  u32(static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534Au);
  glb += json;
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942u);
  glb += bin;
  return glb;
}

// The character tests' scratch folder (under the process's own TMPDIR:
// tests/catch_main.cpp), created if missing.
inline std::filesystem::path temp_dir() {
  const auto dir = std::filesystem::temp_directory_path() / "gatcore_char_tests";
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::string write_temp(const std::string& name, const std::string& bytes) {
  const auto p = temp_dir() / name;
  std::ofstream(p, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return p.string();
}

}  // namespace charfix
