// Compressed and extended glTF (see gltf_extensions.hpp). tinygltf reads the
// JSON and the buffers; two things have to happen around it:
// - before: a meshopt file's "fallback" buffer has no bytes of its own (a
//   .glb loader would hand it the BIN chunk, so its placeholder bytes would
//   be read as data), and a Draco primitive's accessors have no buffer view
//   (tinygltf refuses that); the JSON is patched so tinygltf loads the file,
//   and every patched view is replaced after decoding;
// - after: the compressed views and primitives are decoded into new buffers.
// tinygltf's own optional Draco path is not used: it dereferences missing
// attributes and trusts the counts in the file.
#include "src/character/io/gltf_extensions.hpp"

#include <draco/compression/decode.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <vector>

#include "gatcore/error.hpp"

namespace gatcore::character::gltf_ext {

namespace {

const char* kMeshopt[] = {"EXT_meshopt_compression", "KHR_meshopt_compression"};
const char* kDraco = "KHR_draco_mesh_compression";

bool supported(const std::string& e) {
  if (e == kDraco || e == kMeshopt[0] || e == kMeshopt[1]) return true;
  // The importer reads every accessor component type (quantised data included).
  if (e == "KHR_mesh_quantization") return true;
  // Materials, textures, lights and cameras do not change the skinned geometry gatcore reads.
  for (const char* prefix : {"KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_"})
    if (e.rfind(prefix, 0) == 0) return true;
  return false;
}

template <typename... P>
[[noreturn]] void fail(const std::string& path, const P&... parts) {
  throw InvalidArgument(detail::cat(path, ": ", parts...));
}

std::size_t number(const tinygltf::Value& v, const char* key, const std::string& path, const std::string& what,
                   bool required = true, std::size_t fallback = 0) {
  if (!v.Has(key)) {
    if (required) fail(path, what, " has no '", key, "'");
    return fallback;
  }
  const tinygltf::Value& x = v.Get(key);
  if (!x.IsNumber() && !x.IsInt()) fail(path, what, ": '", key, "' is not a number");
  const double d = x.GetNumberAsDouble();
  if (!(d >= 0.0) || d > 9.0e15 || d != static_cast<double>(static_cast<std::size_t>(d)))
    fail(path, what, ": '", key, "' = ", d, " is not a valid count or offset");
  return static_cast<std::size_t>(d);
}

std::string text(const tinygltf::Value& v, const char* key, const char* fallback) {
  return v.Has(key) && v.Get(key).IsString() ? v.Get(key).Get<std::string>() : std::string(fallback);
}

// The bytes [offset, offset + length) of buffer `b`, checked.
const unsigned char* bytes(const tinygltf::Model& m, std::size_t b, std::size_t offset, std::size_t length,
                           const std::string& path, const std::string& what) {
  if (b >= m.buffers.size()) fail(path, what, " refers to missing buffer ", b);
  const auto& data = m.buffers[b].data;
  if (offset > data.size() || length > data.size() - offset)
    fail(path, what, " reads bytes [", offset, ", ", offset + length, ") of buffer ", b, ", which holds ", data.size());
  return data.data() + offset;
}

int append_view(tinygltf::Model& m, std::vector<unsigned char> data, std::size_t stride) {
  tinygltf::Buffer b;
  b.data = std::move(data);
  tinygltf::BufferView v;
  v.buffer = static_cast<int>(m.buffers.size());
  v.byteOffset = 0;
  v.byteLength = b.data.size();
  v.byteStride = stride;
  m.buffers.push_back(std::move(b));
  m.bufferViews.push_back(v);
  return static_cast<int>(m.bufferViews.size()) - 1;
}

void decode_meshopt(tinygltf::Model& m, const std::string& path) {
  for (std::size_t i = 0; i < m.bufferViews.size(); ++i) {
    tinygltf::BufferView& view = m.bufferViews[i];
    for (const char* name : kMeshopt) {
      const auto it = view.extensions.find(name);
      if (it == view.extensions.end()) continue;
      const tinygltf::Value& e = it->second;
      const std::string what = detail::cat("buffer view ", i, " (", name, ")");
      const std::size_t buffer = number(e, "buffer", path, what), offset = number(e, "byteOffset", path, what, false);
      const std::size_t length = number(e, "byteLength", path, what), stride = number(e, "byteStride", path, what);
      const std::size_t count = number(e, "count", path, what);
      const std::string mode = text(e, "mode", ""), filter = text(e, "filter", "NONE");
      if (stride == 0 || stride > 256 || count > (std::size_t{1} << 31) / stride)
        fail(path, what, ": byteStride ", stride, " and count ", count, " are out of range");
      const unsigned char* src = bytes(m, buffer, offset, length, path, what);
      std::vector<unsigned char> out(count * stride);
      int rc = -1;
      if (mode == "ATTRIBUTES") {
        if (stride % 4 != 0) fail(path, what, ": ATTRIBUTES need a byteStride divisible by 4, got ", stride);
        rc = meshopt_decodeVertexBuffer(out.data(), count, stride, src, length);
      } else if (mode == "TRIANGLES" || mode == "INDICES") {
        if (stride != 2 && stride != 4) fail(path, what, ": ", mode, " need a byteStride of 2 or 4, got ", stride);
        if (mode == "TRIANGLES" && count % 3 != 0) fail(path, what, ": TRIANGLES count ", count, " is not a multiple of 3");
        rc = mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(out.data(), count, stride, src, length)
                                 : meshopt_decodeIndexSequence(out.data(), count, stride, src, length);
      } else {
        fail(path, what, ": unknown mode '", mode, "'");
      }
      if (rc != 0) fail(path, what, ": the compressed data does not decode (", mode, ", ", count, " x ", stride, " bytes)");
      if (filter == "OCTAHEDRAL") {
        if (stride != 4 && stride != 8) fail(path, what, ": OCTAHEDRAL needs a byteStride of 4 or 8");
        meshopt_decodeFilterOct(out.data(), count, stride);
      } else if (filter == "QUATERNION") {
        if (stride != 8) fail(path, what, ": QUATERNION needs a byteStride of 8");
        meshopt_decodeFilterQuat(out.data(), count, stride);
      } else if (filter == "EXPONENTIAL") {
        if (stride % 4 != 0) fail(path, what, ": EXPONENTIAL needs a byteStride divisible by 4");
        meshopt_decodeFilterExp(out.data(), count, stride);
      } else if (filter != "NONE") {
        fail(path, what, ": unknown filter '", filter, "'");
      }
      tinygltf::Buffer decoded;
      decoded.data = std::move(out);
      m.buffers.push_back(std::move(decoded));
      tinygltf::BufferView& v = m.bufferViews[i];
      v.buffer = static_cast<int>(m.buffers.size()) - 1;
      v.byteOffset = 0;
      v.byteLength = m.buffers.back().data.size();
      v.extensions.erase(name);
      break;
    }
  }
  for (tinygltf::Buffer& b : m.buffers)
    for (const char* name : kMeshopt) b.extensions.erase(name);
}

void decode_draco(tinygltf::Model& m, const std::string& path) {
  for (std::size_t mi = 0; mi < m.meshes.size(); ++mi)
    for (std::size_t pi = 0; pi < m.meshes[mi].primitives.size(); ++pi) {
      tinygltf::Primitive& p = m.meshes[mi].primitives[pi];
      const auto it = p.extensions.find(kDraco);
      if (it == p.extensions.end()) continue;
      const tinygltf::Value e = it->second;
      const std::string what = detail::cat("mesh ", mi, " primitive ", pi, " (", kDraco, ")");
      const std::size_t vi = number(e, "bufferView", path, what);
      if (vi >= m.bufferViews.size()) fail(path, what, " refers to missing buffer view ", vi);
      const tinygltf::BufferView& view = m.bufferViews[vi];
      const unsigned char* src =
          bytes(m, static_cast<std::size_t>(view.buffer), view.byteOffset, view.byteLength, path, what);
      draco::DecoderBuffer in;
      in.Init(reinterpret_cast<const char*>(src), view.byteLength);
      draco::Decoder decoder;
      auto decoded = decoder.DecodeMeshFromBuffer(&in);
      if (!decoded.ok()) fail(path, what, ": the Draco data does not decode: ", decoded.status().error_msg_string());
      const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
      if (!mesh) fail(path, what, ": the Draco data holds no mesh");
      const std::size_t points = mesh->num_points();
      auto accessor = [&](int index, const std::string& role) -> tinygltf::Accessor& {
        if (index < 0 || static_cast<std::size_t>(index) >= m.accessors.size())
          fail(path, what, ": ", role, " accessor ", index, " does not exist");
        return m.accessors[static_cast<std::size_t>(index)];
      };
      if (p.indices >= 0) {
        tinygltf::Accessor& a = accessor(p.indices, "indices");
        std::vector<unsigned char> idx(static_cast<std::size_t>(mesh->num_faces()) * 3 * 4);
        for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
          for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = mesh->face(f)[k].value();
            if (v >= points) fail(path, what, ": face ", f.value(), " uses point ", v, " of ", points);
            std::memcpy(idx.data() + (static_cast<std::size_t>(f.value()) * 3 + k) * 4, &v, 4);
          }
        a.bufferView = append_view(m, std::move(idx), 0);
        a.byteOffset = 0;
        a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
        a.count = static_cast<std::size_t>(mesh->num_faces()) * 3;
        a.sparse.isSparse = false;
      }
      if (!e.Has("attributes") || !e.Get("attributes").IsObject()) fail(path, what, " has no 'attributes'");
      const tinygltf::Value& attrs = e.Get("attributes");
      for (const std::string& name : attrs.Keys()) {
        const std::size_t id = number(attrs, name.c_str(), path, what + " attributes");
        const auto pa = p.attributes.find(name);
        if (pa == p.attributes.end()) fail(path, what, ": compressed attribute ", name, " is not an attribute of the primitive");
        tinygltf::Accessor& a = accessor(pa->second, name);
        const draco::PointAttribute* att = mesh->GetAttributeByUniqueId(static_cast<std::uint32_t>(id));
        if (!att) fail(path, what, ": attribute ", name, " (Draco id ", id, ") is not in the compressed data");
        const int comps = tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type));
        if (comps <= 0 || att->num_components() != comps)
          fail(path, what, ": attribute ", name, " has ", static_cast<int>(att->num_components()),
               " components in the compressed data, the accessor expects ", comps);
        // Integer attributes (JOINTS_n) stay unsigned integers; everything
        // else becomes float (Draco applies the normalisation).
        const bool integer = name.rfind("JOINTS_", 0) == 0;
        const std::size_t size = 4;
        std::vector<unsigned char> out(points * static_cast<std::size_t>(comps) * size);
        for (draco::PointIndex i(0); i < static_cast<std::uint32_t>(points); ++i) {
          unsigned char* dst = out.data() + static_cast<std::size_t>(i.value()) * comps * size;
          const bool ok = integer ? att->ConvertValue<std::uint32_t>(att->mapped_index(i), static_cast<std::int8_t>(comps),
                                                                      reinterpret_cast<std::uint32_t*>(dst))
                                  : att->ConvertValue<float>(att->mapped_index(i), static_cast<std::int8_t>(comps),
                                                             reinterpret_cast<float*>(dst));
          if (!ok) fail(path, what, ": attribute ", name, " point ", i.value(), " does not convert");
        }
        a.bufferView = append_view(m, std::move(out), 0);
        a.byteOffset = 0;
        a.componentType = integer ? TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT : TINYGLTF_COMPONENT_TYPE_FLOAT;
        a.normalized = false;
        a.count = points;
        a.sparse.isSparse = false;
      }
      p.extensions.erase(kDraco);
    }
}

void drop(std::vector<std::string>& names, const char* name) {
  names.erase(std::remove(names.begin(), names.end(), std::string(name)), names.end());
}

std::string base_dir(const std::string& path) {
  const std::size_t cut = path.find_last_of("/\\");
  return cut == std::string::npos ? std::string() : path.substr(0, cut);
}

}  // namespace

const char* supported_required_extensions() {
  return "KHR_draco_mesh_compression, EXT_meshopt_compression, KHR_mesh_quantization, and the material, texture and "
         "light extensions, which do not change the geometry";
}

bool load_gltf_model(tinygltf::TinyGLTF& loader, tinygltf::Model* model, std::string* err, std::string* warn,
                     const std::string& path, bool binary) {
  auto plain = [&] {
    return binary ? loader.LoadBinaryFromFile(model, err, warn, path) : loader.LoadASCIIFromFile(model, err, warn, path);
  };
  // The JSON, read here only to check and patch extensions; anything odd is
  // left to tinygltf's own checks and messages.
  std::vector<unsigned char> file;
  {
    std::ifstream in(path, std::ios::binary);
    if (!in) return plain();
    file.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::size_t json_at = 0, json_len = file.size();
  if (binary) {
    auto u32 = [&](std::size_t at) {
      std::uint32_t v;
      std::memcpy(&v, file.data() + at, 4);
      return v;
    };
    if (file.size() < 20 || std::memcmp(file.data(), "glTF", 4) != 0 || u32(16) != 0x4E4F534Au) return plain();
    json_at = 20;
    json_len = u32(12);
    if (json_len > file.size() - 20) return plain();
  }
  nlohmann::json j = nlohmann::json::parse(file.begin() + static_cast<long>(json_at),
                                           file.begin() + static_cast<long>(json_at + json_len), nullptr, false);
  if (j.is_discarded() || !j.is_object()) return plain();
  if (j.contains("extensionsRequired") && j["extensionsRequired"].is_array())
    for (const auto& e : j["extensionsRequired"])
      if (e.is_string() && !supported(e.get<std::string>()))
        throw InvalidArgument(detail::cat(path, ": the file requires the glTF extension '", e.get<std::string>(),
                                          "', which gatcore cannot read (it reads ", supported_required_extensions(),
                                          ")"));
  bool patched = false;
  // Meshopt fallback buffers: one placeholder byte triple instead of
  // whatever tinygltf would give them; nothing reads them after decoding.
  if (j.contains("buffers") && j["buffers"].is_array())
    for (auto& b : j["buffers"]) {
      if (!b.is_object() || !b.contains("extensions") || !b["extensions"].is_object()) continue;
      for (const char* name : kMeshopt)
        if (b["extensions"].contains(name) && b["extensions"][name].is_object() &&
            b["extensions"][name].value("fallback", false)) {
          b["uri"] = "data:application/octet-stream;base64,AAAA";
          b["byteLength"] = 3;
          patched = true;
        }
    }
  // Draco primitives: their accessors point at the compressed view until decoded.
  if (j.contains("meshes") && j["meshes"].is_array() && j.contains("accessors") && j["accessors"].is_array())
    for (auto& mesh : j["meshes"]) {
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
      for (auto& p : mesh["primitives"]) {
        if (!p.is_object() || !p.contains("extensions") || !p["extensions"].is_object() ||
            !p["extensions"].contains(kDraco) || !p["extensions"][kDraco].is_object())
          continue;
        const auto& d = p["extensions"][kDraco];
        if (!d.contains("bufferView") || !d["bufferView"].is_number_unsigned()) continue;
        std::vector<nlohmann::json> used;
        if (p.contains("indices")) used.push_back(p["indices"]);
        if (p.contains("attributes") && p["attributes"].is_object())
          for (const auto& [k, v] : p["attributes"].items()) used.push_back(v);
        for (const auto& a : used)
          if (a.is_number_unsigned() && a.get<std::size_t>() < j["accessors"].size()) {
            auto& acc = j["accessors"][a.get<std::size_t>()];
            if (acc.is_object() && !acc.contains("bufferView")) {
              acc["bufferView"] = d["bufferView"];
              patched = true;
            }
          }
      }
    }
  bool ok;
  if (!patched) {
    ok = plain();
  } else if (binary) {
    std::string js = j.dump();
    while (js.size() % 4) js.push_back(' ');
    std::vector<unsigned char> glb(file.begin(), file.begin() + 12);
    const std::size_t rest_at = 20 + ((json_len + 3) & ~std::size_t{3});
    const std::uint32_t len = static_cast<std::uint32_t>(js.size()), type = 0x4E4F534Au;
    glb.insert(glb.end(), reinterpret_cast<const unsigned char*>(&len), reinterpret_cast<const unsigned char*>(&len) + 4);
    glb.insert(glb.end(), reinterpret_cast<const unsigned char*>(&type), reinterpret_cast<const unsigned char*>(&type) + 4);
    glb.insert(glb.end(), js.begin(), js.end());
    if (rest_at < file.size()) glb.insert(glb.end(), file.begin() + static_cast<long>(rest_at), file.end());
    const std::uint32_t total = static_cast<std::uint32_t>(glb.size());
    std::memcpy(glb.data() + 8, &total, 4);
    ok = loader.LoadBinaryFromMemory(model, err, warn, glb.data(), static_cast<unsigned int>(glb.size()), base_dir(path));
  } else {
    const std::string js = j.dump();
    ok = loader.LoadASCIIFromString(model, err, warn, js.c_str(), static_cast<unsigned int>(js.size()), base_dir(path));
  }
  if (!ok) return false;
  decode_meshopt(*model, path);
  decode_draco(*model, path);
  for (auto* names : {&model->extensionsUsed, &model->extensionsRequired}) {
    drop(*names, kDraco);
    for (const char* name : kMeshopt) drop(*names, name);
  }
  return true;
}

}  // namespace gatcore::character::gltf_ext
