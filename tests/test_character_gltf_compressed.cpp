// Compressed and extended glTF: a character gatcore writes itself, compressed
// here with the libraries' own encoders (Draco: draco::Encoder; meshopt:
// meshopt_encodeVertexBuffer / meshopt_encodeIndexBuffer), must load with
// the same geometry, weights and skeleton as the plain file. The original
// bytes left in the compressed files are overwritten with NaN, so reading a
// placeholder instead of decoding cannot pass. Unsupported required
// extensions and broken compressed data are refused by name.
#include <catch2/catch.hpp>

#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <nlohmann/json.hpp>

#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;
using nlohmann::json;

namespace {

struct Glb {
  json j;
  std::vector<unsigned char> bin;
};

Glb read_glb(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<unsigned char> f((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(f.size() >= 28);
  std::uint32_t jl, bl;
  std::memcpy(&jl, f.data() + 12, 4);
  Glb g;
  g.j = json::parse(f.begin() + 20, f.begin() + 20 + jl);
  const std::size_t b = 20 + jl;
  REQUIRE(f.size() >= b + 8);
  std::memcpy(&bl, f.data() + b, 4);
  g.bin.assign(f.begin() + static_cast<long>(b + 8), f.begin() + static_cast<long>(b + 8 + bl));
  return g;
}

void write_glb(Glb g, const std::string& path) {
  g.j["buffers"][0]["byteLength"] = g.bin.size();
  std::string js = g.j.dump();
  while (js.size() % 4) js.push_back(' ');
  std::vector<unsigned char> bin = g.bin;
  while (bin.size() % 4) bin.push_back(0);
  std::ofstream out(path, std::ios::binary);
  auto u32 = [&](std::uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); };
  out.write("glTF", 4);
  u32(2);
  u32(static_cast<std::uint32_t>(12 + 8 + js.size() + 8 + bin.size()));
  u32(static_cast<std::uint32_t>(js.size()));
  u32(0x4E4F534Au);
  out.write(js.data(), static_cast<long>(js.size()));
  u32(static_cast<std::uint32_t>(bin.size()));
  u32(0x004E4942u);
  out.write(reinterpret_cast<const char*>(bin.data()), static_cast<long>(bin.size()));
}

std::size_t component_size(int ct) { return ct == 5126 || ct == 5125 ? 4 : ct == 5123 || ct == 5122 ? 2 : 1; }
int components(const std::string& t) { return t == "SCALAR" ? 1 : t == "VEC2" ? 2 : t == "VEC3" ? 3 : t == "VEC4" ? 4 : 16; }

// An accessor's elements as bytes (tightly packed, as save_gltf_character writes them).
std::vector<unsigned char> accessor_bytes(const Glb& g, std::size_t a, std::size_t* elem = nullptr) {
  const json& acc = g.j["accessors"][a];
  const json& view = g.j["bufferViews"][acc["bufferView"].get<std::size_t>()];
  const std::size_t es = component_size(acc["componentType"]) * components(acc["type"]);
  const std::size_t start = view.value("byteOffset", 0) + acc.value("byteOffset", 0);
  REQUIRE(view.value("byteStride", es) == es);
  if (elem) *elem = es;
  return {g.bin.begin() + static_cast<long>(start), g.bin.begin() + static_cast<long>(start + es * acc["count"].get<std::size_t>())};
}

// Overwrites a view's bytes with 0xFF (NaN as floats, out-of-range indices).
void poison(Glb& g, std::size_t view) {
  const json& v = g.j["bufferViews"][view];
  std::fill_n(g.bin.begin() + v.value("byteOffset", 0), v["byteLength"].get<std::size_t>(), 0xFF);
}

std::size_t append(Glb& g, const std::vector<unsigned char>& data) {
  while (g.bin.size() % 4) g.bin.push_back(0);
  const std::size_t at = g.bin.size();
  g.bin.insert(g.bin.end(), data.begin(), data.end());
  return at;
}

void require_extension(Glb& g, const char* name) {
  g.j["extensionsUsed"].push_back(name);
  g.j["extensionsRequired"].push_back(name);
}

// Every primitive Draco-compressed: sequential encoding without quantisation
// (lossless), or as exporters write it (edgebreaker, which reorders points,
// with 14-bit positions).
Glb draco_version(Glb g, bool quantised = false) {
  for (auto& mesh : g.j["meshes"])
    for (auto& p : mesh["primitives"]) {
      const std::size_t ia = p["indices"];
      std::size_t isz;
      const auto idx = accessor_bytes(g, ia, &isz);
      const std::size_t nidx = g.j["accessors"][ia]["count"];
      draco::Mesh dm;
      std::size_t points = 0;
      json ids = json::object();
      for (auto& [name, a] : p["attributes"].items()) {
        const json& acc = g.j["accessors"][a.get<std::size_t>()];
        points = acc["count"];
        dm.set_num_points(static_cast<std::uint32_t>(points));
        const int ct = acc["componentType"], nc = components(acc["type"]);
        const draco::DataType dt = ct == 5126 ? draco::DT_FLOAT32 : ct == 5123 ? draco::DT_UINT16 : draco::DT_UINT8;
        const auto type = name == "POSITION" ? draco::GeometryAttribute::POSITION
                          : name == "NORMAL" ? draco::GeometryAttribute::NORMAL
                                             : draco::GeometryAttribute::GENERIC;
        draco::GeometryAttribute ga;
        const std::size_t es = component_size(ct) * static_cast<std::size_t>(nc);
        ga.Init(type, nullptr, static_cast<std::int8_t>(nc), dt, acc.value("normalized", false), static_cast<std::int64_t>(es), 0);
        const int id = dm.AddAttribute(ga, true, static_cast<std::uint32_t>(points));
        const auto data = accessor_bytes(g, a.get<std::size_t>());
        for (std::size_t i = 0; i < points; ++i)
          dm.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(static_cast<std::uint32_t>(i)), data.data() + i * es);
        ids[name] = dm.attribute(id)->unique_id();
      }
      for (std::size_t f = 0; f < nidx / 3; ++f) {
        draco::Mesh::Face face;
        for (int k = 0; k < 3; ++k) {
          std::uint32_t v = 0;
          std::memcpy(&v, idx.data() + (3 * f + k) * isz, isz);
          face[k] = draco::PointIndex(v);
        }
        dm.AddFace(face);
      }
      draco::Encoder enc;
      if (quantised) {
        enc.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
        enc.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
      } else {
        enc.SetEncodingMethod(draco::MESH_SEQUENTIAL_ENCODING);
      }
      draco::EncoderBuffer out;
      REQUIRE(enc.EncodeMeshToBuffer(dm, &out).ok());
      const std::size_t at = append(g, std::vector<unsigned char>(out.data(), out.data() + out.size()));
      g.j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", out.size()}});
      // The accessors lose their views (poisoned first, so stale reads show).
      std::vector<std::size_t> accs = {ia};
      for (auto& [name, a] : p["attributes"].items()) accs.push_back(a);
      for (std::size_t a : accs) {
        poison(g, g.j["accessors"][a]["bufferView"]);
        g.j["accessors"][a].erase("bufferView");
        g.j["accessors"][a].erase("byteOffset");
      }
      p["extensions"]["KHR_draco_mesh_compression"] = {{"bufferView", g.j["bufferViews"].size() - 1}, {"attributes", ids}};
    }
  require_extension(g, "KHR_draco_mesh_compression");
  return g;
}

// Every mesh buffer view meshopt-compressed into buffer 0; the views point
// at a fallback buffer with no bytes of its own.
Glb meshopt_version(Glb g) {
  const std::size_t original = g.bin.size();
  std::set<std::size_t> done;
  for (auto& mesh : g.j["meshes"])
    for (auto& p : mesh["primitives"]) {
      std::vector<std::pair<std::size_t, bool>> accs = {{p["indices"], true}};
      for (auto& [name, a] : p["attributes"].items()) accs.push_back({a, false});
      for (const auto& [a, is_index] : accs) {
        const std::size_t vi = g.j["accessors"][a]["bufferView"];
        if (!done.insert(vi).second) continue;
        std::size_t es;
        const auto data = accessor_bytes(g, a, &es);
        const std::size_t count = g.j["accessors"][a]["count"];
        std::vector<unsigned char> enc;
        if (is_index) {
          std::vector<unsigned int> idx(count);
          for (std::size_t i = 0; i < count; ++i) {
            std::uint32_t v = 0;
            std::memcpy(&v, data.data() + i * es, es);
            idx[i] = v;
          }
          enc.resize(meshopt_encodeIndexBufferBound(count, count));
          enc.resize(meshopt_encodeIndexBuffer(enc.data(), enc.size(), idx.data(), count));
          es = es < 4 ? 2 : 4;
        } else {
          REQUIRE(es % 4 == 0);
          enc.resize(meshopt_encodeVertexBufferBound(count, es));
          enc.resize(meshopt_encodeVertexBuffer(enc.data(), enc.size(), data.data(), count, es));
        }
        REQUIRE(!enc.empty());
        poison(g, vi);
        const std::size_t at = append(g, enc);
        json& view = g.j["bufferViews"][vi];
        view["buffer"] = 1;
        if (!is_index) view["byteStride"] = es;
        view["extensions"]["EXT_meshopt_compression"] = {{"buffer", 0},   {"byteOffset", at},
                                                         {"byteLength", enc.size()}, {"byteStride", es},
                                                         {"count", count}, {"mode", is_index ? "TRIANGLES" : "ATTRIBUTES"}};
      }
    }
  g.j["buffers"][0]["byteLength"] = g.bin.size();
  g.j["buffers"].push_back({{"byteLength", original}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}});
  require_extension(g, "EXT_meshopt_compression");
  return g;
}

std::string temp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("gatcore_compressed_" + name)).string();
}

// Triangles with each rotated to start at its smallest vertex: meshopt's
// index codec keeps the triangle order and winding but may rotate a
// triangle's vertices.
std::vector<std::int32_t> canonical(std::vector<std::int32_t> t) {
  for (std::size_t i = 0; i + 2 < t.size(); i += 3)
    while (t[i] > t[i + 1] || t[i] > t[i + 2]) std::rotate(t.begin() + static_cast<long>(i), t.begin() + static_cast<long>(i + 1), t.begin() + static_cast<long>(i + 3));
  return t;
}

void check_same(const Character& a, const Character& b) {
  REQUIRE(a.mesh.num_vertices() == b.mesh.num_vertices());
  CHECK(a.mesh.positions == b.mesh.positions);
  CHECK(canonical(a.mesh.triangles) == canonical(b.mesh.triangles));
  CHECK(a.mesh.weights.ptr == b.mesh.weights.ptr);
  CHECK(a.mesh.weights.joint == b.mesh.weights.joint);
  CHECK(a.mesh.weights.weight == b.mesh.weights.weight);
  CHECK(a.skeleton.names == b.skeleton.names);
  CHECK(a.skeleton.inverse_bind == b.skeleton.inverse_bind);
  CHECK(a.welded_from_file == b.welded_from_file);
}

}  // namespace

TEST_CASE("Draco and meshopt glTF files load with the geometry of their plain form", "[character][gltf][compressed]") {
  const std::string plain = temp("plain.glb");
  save_gltf_character(procedural_character(), plain);
  const Character ref = load_gltf(plain);
  const Glb g = read_glb(plain);
  for (const auto& [name, file] : {std::pair<const char*, Glb>{"draco", draco_version(g)}, {"meshopt", meshopt_version(g)}}) {
    INFO(name);
    const std::string path = temp(std::string(name) + ".glb");
    write_glb(file, path);
    const Character ch = load_gltf(path);
    check_same(ref, ch);
    // Writing weights back gives a plain file that loads the same again.
    const std::string out = temp(std::string(name) + "_weights.glb");
    save_gltf_with_weights(path, ch, ch.mesh.weights, out);
    check_same(ref, load_gltf(out));
    const Glb written = read_glb(out);
    CHECK_FALSE(written.j.contains("extensionsRequired"));
  }
}

TEST_CASE("a Draco file as exporters write it (edgebreaker, quantised positions) loads the same surface",
          "[character][gltf][compressed]") {
  const std::string plain = temp("plain3.glb");
  save_gltf_character(procedural_character(), plain);
  const Character ref = load_gltf(plain);
  const std::string path = temp("draco_q.glb");
  write_glb(draco_version(read_glb(plain), true), path);
  const Character ch = load_gltf(path);
  REQUIRE(ch.mesh.num_vertices() == ref.mesh.num_vertices());
  CHECK(ch.mesh.num_triangles() == ref.mesh.num_triangles());
  CHECK(ch.skeleton.inverse_bind == ref.skeleton.inverse_bind);
  // Every vertex within the quantisation step of a plain vertex, with the same weights.
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (std::size_t i = 0; i < ref.mesh.positions.size(); ++i)
    lo[i % 3] = std::min(lo[i % 3], ref.mesh.positions[i]), hi[i % 3] = std::max(hi[i % 3], ref.mesh.positions[i]);
  const float step = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}) / 16383.0f;
  int far = 0, other_weights = 0;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    std::int64_t best = -1;
    float bd = 1e30f;
    for (std::int64_t u = 0; u < ref.mesh.num_vertices(); ++u) {
      float d = 0.0f;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(ch.mesh.positions[3 * v + c] - ref.mesh.positions[3 * u + c]));
      if (d < bd) bd = d, best = u;
    }
    far += bd > step;
    const auto& a = ch.mesh.weights;
    const auto& b = ref.mesh.weights;
    const bool same = a.ptr[v + 1] - a.ptr[v] == b.ptr[best + 1] - b.ptr[best] &&
                      std::equal(a.joint.begin() + a.ptr[v], a.joint.begin() + a.ptr[v + 1], b.joint.begin() + b.ptr[best]);
    other_weights += !same;
  }
  CHECK(far == 0);
  CHECK(other_weights == 0);
}

TEST_CASE("required glTF extensions gatcore cannot read, and broken compressed data, are refused by name",
          "[character][gltf][compressed]") {
  const std::string plain = temp("plain2.glb");
  save_gltf_character(procedural_character(), plain);
  const Glb g = read_glb(plain);
  Glb unknown = g;
  require_extension(unknown, "KHR_gaussian_splatting");
  write_glb(unknown, temp("unknown.glb"));
  CHECK_THROWS_WITH(load_gltf(temp("unknown.glb")), Contains("unknown.glb") && Contains("KHR_gaussian_splatting"));
  // Materials-only extensions do not change the geometry: accepted.
  Glb unlit = g;
  require_extension(unlit, "KHR_materials_unlit");
  write_glb(unlit, temp("unlit.glb"));
  CHECK_NOTHROW(load_gltf(temp("unlit.glb")));
  // Corrupted compressed data: an error naming the file, not a crash.
  for (const char* kind : {"draco", "meshopt"}) {
    INFO(kind);
    Glb bad = std::string(kind) == "draco" ? draco_version(g) : meshopt_version(g);
    const json& v = bad.j["bufferViews"].back();
    const std::size_t at = std::string(kind) == "draco" ? v["byteOffset"].get<std::size_t>()
                                                         : v["extensions"]["EXT_meshopt_compression"]["byteOffset"].get<std::size_t>();
    for (std::size_t i = 0; i < 16; ++i) bad.bin[at + i] = static_cast<unsigned char>(0xA5 ^ i);
    const std::string path = temp(std::string("bad_") + kind + ".glb");
    write_glb(bad, path);
    CHECK_THROWS_AS(load_gltf(path), gatcore::InvalidArgument);
    CHECK_THROWS_WITH(load_gltf(path), Contains(path));
    // A view that points past its buffer.
    Glb past = std::string(kind) == "draco" ? draco_version(g) : meshopt_version(g);
    if (std::string(kind) == "draco") past.j["bufferViews"].back()["byteLength"] = 1u << 30;
    else past.j["bufferViews"].back()["extensions"]["EXT_meshopt_compression"]["byteLength"] = 1u << 30;
    write_glb(past, temp(std::string("past_") + kind + ".glb"));
    CHECK_THROWS_AS(load_gltf(temp(std::string("past_") + kind + ".glb")), gatcore::InvalidArgument);
  }
}
