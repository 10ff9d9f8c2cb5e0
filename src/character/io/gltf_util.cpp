#include "src/character/io/gltf_util.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>

#include "gatcore/atomic_file.hpp"
#include "gatcore/error.hpp"
#include "src/character/io/gltf_extensions.hpp"

namespace gatcore::character::gltf_util {

bool is_glb(const std::string& p) {
  return p.size() >= 4 && (p.compare(p.size() - 4, 4, ".glb") == 0 || p.compare(p.size() - 4, 4, ".GLB") == 0);
}

tinygltf::Model read_model(const std::string& path) {
  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  // Images are carried through untouched, never decoded.
  gltf.SetImageLoader(
      [](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
        return true;
      },
      nullptr);
  ResourceGuard guard;
  confine_resources(gltf, guard, path);
  std::string err, warn;
  const bool ok = gltf_ext::load_gltf_model(gltf, &model, &err, &warn, path, is_glb(path));
  GATCORE_CHECK(ok, path, ": cannot read the glTF file: ", err);
  if (model.buffers.empty()) model.buffers.emplace_back();
  return model;
}

int append_accessor(tinygltf::Model& m, const void* data, std::size_t bytes, int component_type, int type,
                    std::size_t count) {
  if (m.buffers.empty()) m.buffers.emplace_back();
  auto& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = bytes;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  m.bufferViews.push_back(v);
  tinygltf::Accessor a;
  a.bufferView = static_cast<int>(m.bufferViews.size()) - 1;
  a.componentType = component_type;
  a.type = type;
  a.count = count;
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size()) - 1;
}

int append_vec3(tinygltf::Model& m, const std::vector<float>& xyz) {
  const std::size_t n = xyz.size() / 3;
  std::vector<double> lo(3, n ? std::numeric_limits<double>::max() : 0.0), hi(3, n ? -std::numeric_limits<double>::max() : 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min<double>(lo[c], xyz[3 * i + c]);
      hi[c] = std::max<double>(hi[c], xyz[3 * i + c]);
    }
  const int a = append_accessor(m, xyz.data(), xyz.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                TINYGLTF_TYPE_VEC3, n);
  m.accessors[a].minValues = lo;
  m.accessors[a].maxValues = hi;
  return a;
}

Transform node_local(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    Mat4 m;
    for (int i = 0; i < 16; ++i) m[i] = static_cast<float>(n.matrix[i]);
    return to_transform(m);
  }
  Transform t;
  if (n.translation.size() == 3)
    for (int i = 0; i < 3; ++i) t.translation[i] = static_cast<float>(n.translation[i]);
  if (n.rotation.size() == 4) {
    for (int i = 0; i < 4; ++i) t.rotation[i] = static_cast<float>(n.rotation[i]);
    t.rotation = quat_normalize(t.rotation);  // files store slightly unnormalised quaternions
  }
  if (n.scale.size() == 3)
    for (int i = 0; i < 3; ++i) t.scale[i] = static_cast<float>(n.scale[i]);
  return t;
}

Mat4 node_matrix(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {  // exactly the file's matrix (no TRS round trip)
    Mat4 m;
    for (int i = 0; i < 16; ++i) m[i] = static_cast<float>(n.matrix[i]);
    return m;
  }
  return to_matrix(node_local(n));
}

std::vector<Mat4> node_globals(const tinygltf::Model& m, const std::string& file) {
  const int n = static_cast<int>(m.nodes.size());
  std::vector<int> parent(n, -1);
  for (int i = 0; i < n; ++i)
    for (int c : m.nodes[i].children) {
      GATCORE_CHECK(c >= 0 && c < n && parent[c] < 0, file, ": node ", i, " has a bad or shared child ", c);
      parent[c] = i;
    }
  std::vector<Mat4> g(n);
  std::vector<char> state(n, 0);  // 0 todo, 1 in progress, 2 done
  for (int i = 0; i < n; ++i) {
    std::vector<int> chain;
    for (int x = i; x >= 0 && state[x] != 2; x = parent[x]) {
      GATCORE_CHECK(state[x] == 0, file, ": the node hierarchy has a cycle at node ", x);
      state[x] = 1;
      chain.push_back(x);
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const int x = *it;
      g[x] = parent[x] >= 0 ? mul(g[parent[x]], node_matrix(m.nodes[x])) : node_matrix(m.nodes[x]);
      state[x] = 2;
    }
  }
  return g;
}

void write_model_atomic(tinygltf::Model& m, const std::string& path) {
  std::ostringstream os;
  tinygltf::TinyGLTF gltf;
  const bool ok = gltf.WriteGltfSceneToStream(&m, os, !is_glb(path), is_glb(path));
  GATCORE_CHECK(ok && os.good(), path, ": cannot serialise the glTF model (nothing written)");
  write_file_atomic(path, os.str());
}

namespace {

bool guarded_read(std::vector<unsigned char>* out, std::string* err, const std::string& file, void* user) {
  const auto* g = static_cast<const ResourceGuard*>(user);
  std::error_code ec;
  const std::filesystem::path abs = std::filesystem::weakly_canonical(file, ec);
  const std::filesystem::path rel = abs.lexically_relative(g->root);
  const bool inside = !ec && !rel.empty() && *rel.begin() != ".." && rel.is_relative();
  if (!inside && abs.string() != g->model) {
    if (err)
      *err += "refusing to read '" + file + "': outside the model's folder '" + g->root +
              "' (GltfImportOptions::resource_root widens it)";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, file, nullptr);
}

bool plain_exists(const std::string& file, void*) { return tinygltf::FileExists(file, nullptr); }
std::string plain_expand(const std::string& file, void*) { return file; }  // no shell-style expansion
bool no_write(std::string* err, const std::string& file, const std::vector<unsigned char>&, void*) {
  if (err) *err += "refusing to write '" + file + "' while loading";
  return false;
}

}  // namespace

void confine_resources(tinygltf::TinyGLTF& loader, ResourceGuard& guard, const std::string& model_path,
                       const std::string& root) {
  namespace fs = std::filesystem;
  std::error_code ec;
  guard.model = fs::weakly_canonical(model_path, ec).string();
  const fs::path r = root.empty() ? fs::path(guard.model).parent_path() : fs::weakly_canonical(root, ec);
  guard.root = r.string();
  tinygltf::FsCallbacks cb{};
  cb.FileExists = &plain_exists;
  cb.ExpandFilePath = &plain_expand;
  cb.ReadWholeFile = &guarded_read;
  cb.WriteWholeFile = &no_write;
  cb.user_data = &guard;
  loader.SetFsCallbacks(cb);
}

}  // namespace gatcore::character::gltf_util
