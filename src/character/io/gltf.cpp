#include "gatcore/character/io/gltf.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <unordered_map>

#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_EXTERNAL_IMAGE
#include <tiny_gltf.h>

#include "gatcore/error.hpp"
#include "src/character/io/gltf_extensions.hpp"
#include "src/character/io/gltf_util.hpp"
#include "src/character/rig/weld.hpp"

namespace gatcore::character {

namespace {

struct Reader {
  const tinygltf::Model& m;
  const std::string& file;

  template <class... A>
  [[noreturn]] void fail(const A&... parts) const {
    throw InvalidArgument(detail::cat(file, ": ", parts...));
  }

  // Reads accessor `index` as `count x comps` floats (normalised integers
  // converted per the glTF spec).
  std::vector<float> floats(int index, int comps, const std::string& what) const {
    std::vector<float> out;
    read(index, comps, what, [&](const unsigned char* p, int ct, bool norm) {
      for (int c = 0; c < comps; ++c) out.push_back(component(p, ct, c, norm));
    });
    for (std::size_t i = 0; i < out.size(); ++i)
      if (!std::isfinite(out[i])) fail(what, ": element ", i / comps, " is not finite (", out[i], ")");
    return out;
  }

  std::vector<std::uint32_t> uints(int index, int comps, const std::string& what) const {
    std::vector<std::uint32_t> out;
    read(index, comps, what, [&](const unsigned char* p, int ct, bool) {
      for (int c = 0; c < comps; ++c) {
        switch (ct) {
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: out.push_back(p[c]); break;
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t v;
            std::memcpy(&v, p + 2 * c, 2);
            out.push_back(v);
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            std::uint32_t v;
            std::memcpy(&v, p + 4 * c, 4);
            out.push_back(v);
            break;
          }
          default: fail(what, ": expected unsigned integer components, got component type ", ct);
        }
      }
    });
    return out;
  }

  std::size_t count(int index) const { return m.accessors.at(static_cast<std::size_t>(index)).count; }

 private:
  static float component(const unsigned char* p, int ct, int c, bool norm) {
    switch (ct) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: {
        float v;
        std::memcpy(&v, p + 4 * c, 4);
        return v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return norm ? p[c] / 255.0f : p[c];
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const float v = static_cast<signed char>(p[c]);
        return norm ? std::max(v / 127.0f, -1.0f) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        std::uint16_t v;
        std::memcpy(&v, p + 2 * c, 2);
        return norm ? v / 65535.0f : v;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        std::int16_t v;
        std::memcpy(&v, p + 2 * c, 2);
        return norm ? std::max(v / 32767.0f, -1.0f) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        std::uint32_t v;
        std::memcpy(&v, p + 4 * c, 4);
        return static_cast<float>(v);
      }
      default: return std::nanf("");
    }
  }

  template <class F>
  void read(int index, int comps, const std::string& what, F&& each) const {
    if (index < 0 || index >= static_cast<int>(m.accessors.size()))
      fail(what, ": accessor ", index, " does not exist (", m.accessors.size(), " accessors)");
    const tinygltf::Accessor& a = m.accessors[index];
    if (a.sparse.isSparse) fail(what, ": sparse accessors are not supported (accessor ", index, ")");
    if (tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)) != comps)
      fail(what, ": accessor ", index, " has ", tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(a.type)),
           " components per element, expected ", comps);
    if (a.count == 0) return;
    if (a.bufferView < 0 || a.bufferView >= static_cast<int>(m.bufferViews.size()))
      fail(what, ": accessor ", index, " has no valid buffer view");
    const tinygltf::BufferView& v = m.bufferViews[a.bufferView];
    if (v.buffer < 0 || v.buffer >= static_cast<int>(m.buffers.size()))
      fail(what, ": buffer view ", a.bufferView, " references missing buffer ", v.buffer);
    const auto& data = m.buffers[v.buffer].data;
    const int csize = tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(a.componentType));
    if (csize <= 0) fail(what, ": accessor ", index, " has invalid component type ", a.componentType);
    const int stride = a.ByteStride(v);
    if (stride <= 0) fail(what, ": accessor ", index, " has an invalid byte stride");
    const std::size_t elem = static_cast<std::size_t>(csize) * comps;
    const std::size_t begin = v.byteOffset + a.byteOffset;
    const std::size_t end = begin + static_cast<std::size_t>(stride) * (a.count - 1) + elem;
    if (end > v.byteOffset + v.byteLength || end > data.size())
      fail(what, ": accessor ", index, " reads bytes [", begin, ", ", end, ") past the end of its data (",
           std::min<std::size_t>(v.byteOffset + v.byteLength, data.size()), " bytes): truncated file?");
    for (std::size_t i = 0; i < a.count; ++i) each(data.data() + begin + i * stride, a.componentType, a.normalized);
  }
};

// glTF requires POSITION's min and max, with every position inside them. A
// corrupt buffer's positions (finite, yet 1e38 apart where the accessor
// declares a 2-unit box) otherwise load, and the weld merges the mesh into a
// handful of vertices without a word. Slack: 1 % of the box's size or
// magnitude, above any exporter's rounding of the bounds and a Draco
// decoder's quantisation error (8 bits: 0.2 %).
void check_position_bounds(const Reader& rd, int index, const std::vector<float>& p, const std::string& what) {
  const tinygltf::Accessor& a = rd.m.accessors[static_cast<std::size_t>(index)];
  if (a.minValues.size() != 3 || a.maxValues.size() != 3) return;  // not declared: nothing to hold them to
  double size = 1e-6;
  for (int c = 0; c < 3; ++c)
    size = std::max({size, a.maxValues[c] - a.minValues[c], std::abs(a.minValues[c]), std::abs(a.maxValues[c])});
  const double slack = 0.01 * size;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const int c = static_cast<int>(i % 3);
    if (!(p[i] >= a.minValues[c] - slack && p[i] <= a.maxValues[c] + slack))
      rd.fail(what, ": vertex ", i / 3, " has ", "xyz"[c], " = ", p[i], ", outside the accessor's declared min ",
              a.minValues[c], " / max ", a.maxValues[c], " (accessor ", index, "; a corrupt buffer or bounds)");
  }
}

using gltf_util::node_local;
using gltf_util::node_matrix;

// Sampled channel value at time t.
struct Channel {
  int joint;
  int path;  // 0 translation, 1 rotation, 2 scale
  std::vector<float> times, values;
  int comps;
  int interp;  // 0 linear, 1 step, 2 cubic spline (middle values, linear)
};

void sample(const Channel& c, float t, Transform& out) {
  const std::size_t n = c.times.size();
  if (n == 0) return;
  auto value = [&](std::size_t k) {
    const std::size_t idx = c.interp == 2 ? 3 * k + 1 : k;
    return c.values.data() + idx * c.comps;
  };
  std::size_t k1 = static_cast<std::size_t>(std::upper_bound(c.times.begin(), c.times.end(), t) - c.times.begin());
  const std::size_t k0 = k1 == 0 ? 0 : k1 - 1;
  k1 = std::min(k1, n - 1);
  float u = 0.0f;
  if (k1 != k0 && c.interp != 1 && c.times[k1] > c.times[k0]) u = (t - c.times[k0]) / (c.times[k1] - c.times[k0]);
  u = std::clamp(u, 0.0f, 1.0f);
  const float *a = value(k0), *b = value(k1);
  if (c.path == 1) {
    out.rotation = quat_slerp({a[0], a[1], a[2], a[3]}, {b[0], b[1], b[2], b[3]}, u);
  } else {
    Vec3& dst = c.path == 0 ? out.translation : out.scale;
    for (int i = 0; i < 3; ++i) dst[i] = a[i] + u * (b[i] - a[i]);
  }
}

}  // namespace

Character load_gltf(const std::string& path, const GltfImportOptions& opt) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(
      [](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
        return true;  // images are kept as bytes, never decoded
      },
      nullptr);
  std::string err, warn;
  const bool binary = path.size() >= 4 && (path.compare(path.size() - 4, 4, ".glb") == 0 ||
                                           path.compare(path.size() - 4, 4, ".GLB") == 0);
  {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    GATCORE_CHECK(f != nullptr, path, ": cannot open file");
    std::fclose(f);
  }
  gltf_util::ResourceGuard guard;
  gltf_util::confine_resources(loader, guard, path, opt.resource_root);
  const bool ok = gltf_ext::load_gltf_model(loader, &model, &err, &warn, path, binary);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw InvalidArgument(detail::cat(path, ": not a readable glTF 2.0 ", binary ? "binary (.glb)" : "(.gltf)",
                                      " file: ", err.empty() ? std::string("unknown error") : err));
  }
  const Reader rd{model, path};
  const int num_nodes = static_cast<int>(model.nodes.size());

  // Node hierarchy and rest globals.
  std::vector<int> node_parent(num_nodes, -1);
  for (int n = 0; n < num_nodes; ++n)
    for (int c : model.nodes[n].children) {
      if (c < 0 || c >= num_nodes) rd.fail("node ", n, " has missing child ", c);
      if (node_parent[c] >= 0) rd.fail("node ", c, " has two parents");
      node_parent[c] = n;
    }
  std::vector<Mat4> node_global(num_nodes);
  std::vector<char> done(num_nodes, 0);
  for (int n = 0; n < num_nodes; ++n) {
    std::vector<int> chain;
    for (int x = n; x >= 0 && !done[x]; x = node_parent[x]) {
      chain.push_back(x);
      if (chain.size() > static_cast<std::size_t>(num_nodes)) rd.fail("the node hierarchy has a cycle");
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const int x = *it, p = node_parent[x];
      node_global[x] = p >= 0 ? mul(node_global[p], node_matrix(model.nodes[x])) : node_matrix(model.nodes[x]);
      done[x] = 1;
    }
  }

  // Without skins (an animation exported without its mesh, read as a motion
  // by request) the skeleton is the animated nodes and the nodes between them.
  const bool no_skin = model.skins.empty();
  if (no_skin && !opt.allow_no_skin) rd.fail("no skin: the file has no skinned character");
  std::vector<char> in_skin(num_nodes, 0);
  if (no_skin) {
    for (const auto& anim : model.animations)
      for (const auto& c : anim.channels)
        if (c.target_node >= 0 && c.target_node < num_nodes && model.nodes[c.target_node].mesh < 0) in_skin[c.target_node] = 1;
    if (std::find(in_skin.begin(), in_skin.end(), 1) == in_skin.end())
      rd.fail("no skin: the file has no skinned character and no animated nodes");
  }
  for (std::size_t s = 0; s < model.skins.size(); ++s) {
    if (model.skins[s].joints.empty()) rd.fail("skin ", s, " has no joints");
    for (int j : model.skins[s].joints) {
      if (j < 0 || j >= num_nodes) rd.fail("skin ", s, " references missing node ", j);
      in_skin[j] = 1;
    }
  }
  // Skeleton nodes: skin joints plus every node between a joint and a joint ancestor.
  std::vector<char> in_skel = in_skin;
  for (int n = 0; n < num_nodes; ++n) {
    if (!in_skin[n]) continue;
    std::vector<int> path;
    int last = -1;
    for (int x = node_parent[n]; x >= 0; x = node_parent[x]) {
      path.push_back(x);
      if (in_skin[x]) last = static_cast<int>(path.size());
    }
    for (int i = 0; i < last; ++i) in_skel[path[i]] = 1;
  }
  std::vector<std::vector<int>> node_children(num_nodes);
  for (int n = 0; n < num_nodes; ++n)
    if (node_parent[n] >= 0) node_children[node_parent[n]].push_back(n);
  std::vector<int> joint_of_node(num_nodes, -1), node_of_joint;
  for (int n = 0; n < num_nodes; ++n) {
    if (!in_skel[n] || (node_parent[n] >= 0 && in_skel[node_parent[n]])) continue;
    std::vector<int> stack{n};  // preorder DFS: parents before children
    while (!stack.empty()) {
      const int x = stack.back();
      stack.pop_back();
      joint_of_node[x] = static_cast<int>(node_of_joint.size());
      node_of_joint.push_back(x);
      for (auto it = node_children[x].rbegin(); it != node_children[x].rend(); ++it)
        if (in_skel[*it]) stack.push_back(*it);
    }
  }

  Character ch;
  ch.name = path;
  Skeleton& sk = ch.skeleton;
  const int J = static_cast<int>(node_of_joint.size());
  std::map<std::string, int> name_count;
  for (int j = 0; j < J; ++j) {
    const int n = node_of_joint[j];
    // Unnamed nodes: Blender's name for them (its glTF importer says Node_2), so a
    // joint is called the same here and there.
    std::string name = model.nodes[n].name.empty() ? "Node_" + std::to_string(n) : model.nodes[n].name;
    if (name_count[name]++ > 0) name += "#" + std::to_string(n);
    sk.names.push_back(name);
    const int p = node_parent[n];
    sk.parents.push_back(p >= 0 && in_skel[p] ? joint_of_node[p] : -1);
    sk.rest_local.push_back(node_local(model.nodes[n]));
    sk.root_parent.push_back(p >= 0 && !in_skel[p] ? node_global[p] : mat4_identity());
    sk.inverse_bind.push_back(Mat4{});
    ch.joint_nodes.push_back(n);
  }
  // Each skin maps its own mesh space to the joints. Exporters write one skin
  // per object, its inverse bind matrices relative to that object's
  // transform (Blender does), so one joint can have different matrices in
  // different skins; taking the first skin's for every mesh leaves the
  // others' vertices off their bones. The character has one bind space: that
  // of the skin binding the most vertices. Every other skin's meshes are
  // brought into it through the joints it shares (skin_to_bind), and its
  // other joints' matrices are expressed in it.
  std::vector<std::vector<Mat4>> skin_ibm(model.skins.size());
  for (std::size_t s = 0; s < model.skins.size(); ++s) {
    const auto& skin = model.skins[s];
    skin_ibm[s].assign(skin.joints.size(), mat4_identity());
    if (skin.inverseBindMatrices < 0) continue;
    const std::vector<float> ibm =
        rd.floats(skin.inverseBindMatrices, 16, "skin " + std::to_string(s) + " inverseBindMatrices");
    if (ibm.size() != 16 * skin.joints.size())
      rd.fail("skin ", s, " has ", ibm.size() / 16, " inverse bind matrices for ", skin.joints.size(), " joints");
    for (std::size_t k = 0; k < skin.joints.size(); ++k) {
      Mat4& m = skin_ibm[s][k];
      std::copy(ibm.begin() + 16 * k, ibm.begin() + 16 * (k + 1), m.begin());
      // A singular inverse bind matrix (all zeros, a zero scale) has no
      // bind pose to return to: every skinned vertex would collapse.
      const double det = double(m[0]) * (double(m[5]) * m[10] - double(m[9]) * m[6]) -
                         double(m[4]) * (double(m[1]) * m[10] - double(m[9]) * m[2]) +
                         double(m[8]) * (double(m[1]) * m[6] - double(m[5]) * m[2]);
      if (!(std::abs(det) > 1e-12) || !std::isfinite(det))
        rd.fail("skin ", s, " inverse bind matrix ", k, " (joint '", model.nodes[skin.joints[k]].name,
                "') is not invertible (determinant ", det, ")");
    }
  }
  std::vector<std::int64_t> skin_vertices(model.skins.size(), 0);
  for (const auto& node : model.nodes) {
    if (node.skin < 0 || node.skin >= static_cast<int>(model.skins.size()) || node.mesh < 0 ||
        node.mesh >= static_cast<int>(model.meshes.size()))
      continue;  // reported when the meshes are read
    for (const auto& prim : model.meshes[node.mesh].primitives) {
      const auto it = prim.attributes.find("POSITION");
      if (it != prim.attributes.end() && it->second >= 0 && it->second < static_cast<int>(model.accessors.size()))
        skin_vertices[node.skin] += static_cast<std::int64_t>(model.accessors[it->second].count);
    }
  }
  const std::size_t ref_skin = static_cast<std::size_t>(
      std::max_element(skin_vertices.begin(), skin_vertices.end()) - skin_vertices.begin());
  std::vector<std::size_t> skin_order;
  if (!no_skin) skin_order.push_back(ref_skin);
  for (std::size_t s = 0; s < model.skins.size(); ++s)
    if (s != ref_skin) skin_order.push_back(s);
  std::vector<char> has_ibm(J, 0);
  std::vector<std::vector<int>> skin_joint(model.skins.size());  // skin-local -> skeleton joint
  std::vector<Mat4> skin_to_bind(model.skins.size(), mat4_identity());
  // Per skin and skin joint: the skin's mesh space -> the bind space as that
  // joint sees it. All equal for a skin bound in the same pose as the
  // reference; blended per vertex by its weights otherwise.
  std::vector<std::vector<Mat4>> joint_to_bind(model.skins.size());
  std::vector<char> skin_moves(model.skins.size(), 0);  // some joint_to_bind is not the identity
  for (const std::size_t s : skin_order) try {
    const auto& skin = model.skins[s];
    for (int n : skin.joints) skin_joint[s].push_back(joint_of_node[n]);
    // (Matrices equal to the reference's give the identity exactly.)
    const auto to_bind_via = [&](std::size_t k) {
      const Mat4& ref = sk.inverse_bind[skin_joint[s][k]];
      return ref == skin_ibm[s][k] ? mat4_identity() : mul(inverse(ref), skin_ibm[s][k]);
    };
    for (std::size_t k = 0; k < skin.joints.size() && s != ref_skin; ++k)
      if (has_ibm[skin_joint[s][k]]) {
        skin_to_bind[s] = to_bind_via(k);
        break;
      }
    const Mat4 from_bind = inverse(skin_to_bind[s]);
    joint_to_bind[s].assign(skin.joints.size(), skin_to_bind[s]);
    for (std::size_t k = 0; k < skin.joints.size(); ++k) {
      const int j = skin_joint[s][k];
      if (!has_ibm[j]) {
        sk.inverse_bind[j] = s == ref_skin ? skin_ibm[s][k] : mul(skin_ibm[s][k], from_bind);
        has_ibm[j] = 1;
      } else if (s != ref_skin) {
        joint_to_bind[s][k] = to_bind_via(k);
      }
    }
    for (const Mat4& x : joint_to_bind[s]) skin_moves[s] = skin_moves[s] || x != mat4_identity();
  } catch (const InvalidArgument& e) {  // products of extreme matrices that no longer invert
    rd.fail("skin ", s, "'s inverse bind matrices do not map into skin ", ref_skin, "'s bind space (", e.what(), ")");
  }
  for (int j = 0; j < J; ++j)
    if (!has_ibm[j]) sk.inverse_bind[j] = inverse(node_global[node_of_joint[j]]);
  sk.validate(path.c_str());

  // Skinned primitives, concatenated (file vertices).
  std::vector<float> pos;
  std::vector<std::vector<std::pair<int, float>>> infl;
  std::vector<std::int32_t> tris;
  for (int n = 0; n < num_nodes; ++n) {
    const auto& node = model.nodes[n];
    if (node.mesh < 0) continue;
    if (node.mesh >= static_cast<int>(model.meshes.size())) rd.fail("node ", n, " references missing mesh ", node.mesh);
    if (node.skin < 0) continue;  // unskinned props are not part of the character
    if (node.skin >= static_cast<int>(model.skins.size())) rd.fail("node ", n, " references missing skin ", node.skin);
    const auto& mesh = model.meshes[node.mesh];
    for (std::size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
      const auto& prim = mesh.primitives[pi];
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
          prim.mode != TINYGLTF_MODE_TRIANGLE_FAN)
        continue;  // points / lines
      const std::string what = "mesh '" + mesh.name + "' (" + std::to_string(node.mesh) + ") primitive " +
                               std::to_string(pi);
      auto attr = [&](const std::string& a) {
        auto it = prim.attributes.find(a);
        return it == prim.attributes.end() ? -1 : it->second;
      };
      if (attr("POSITION") < 0) rd.fail(what, " has no POSITION");
      if (attr("JOINTS_0") < 0 || attr("WEIGHTS_0") < 0)
        rd.fail(what, " is on skinned node ", n, " but has no JOINTS_0 / WEIGHTS_0 (missing skin weights)");
      const std::vector<float> p = rd.floats(attr("POSITION"), 3, what + " POSITION");
      check_position_bounds(rd, attr("POSITION"), p, what + " POSITION");
      const std::size_t nv = p.size() / 3;
      const std::int64_t base = static_cast<std::int64_t>(pos.size() / 3);
      pos.insert(pos.end(), p.begin(), p.end());
      infl.resize(infl.size() + nv);
      const auto& sj = skin_joint[node.skin];
      const bool to_bind = skin_moves[node.skin];
      // Per vertex, its weights' blend of joint_to_bind (skins not the reference).
      std::vector<std::array<double, 16>> blend(to_bind ? nv : 0, std::array<double, 16>{});
      std::vector<double> blend_sum(to_bind ? nv : 0, 0.0);
      for (int set = 0; attr("JOINTS_" + std::to_string(set)) >= 0; ++set) {
        const std::string js = "JOINTS_" + std::to_string(set), ws = "WEIGHTS_" + std::to_string(set);
        if (attr(ws) < 0) rd.fail(what, " has ", js, " but no ", ws);
        const auto jv = rd.uints(attr(js), 4, what + " " + js);
        const auto wv = rd.floats(attr(ws), 4, what + " " + ws);
        if (jv.size() != 4 * nv || wv.size() != 4 * nv)
          rd.fail(what, " ", js, "/", ws, " have ", jv.size() / 4, "/", wv.size() / 4, " elements for ", nv,
                  " vertices");
        for (std::size_t v = 0; v < nv; ++v)
          for (int c = 0; c < 4; ++c) {
            const float w = wv[4 * v + c];
            if (w < 0.0f) rd.fail(what, " vertex ", v, " has negative weight ", w);
            if (w == 0.0f) continue;
            if (jv[4 * v + c] >= sj.size())
              rd.fail(what, " vertex ", v, " has weight ", w, " on joint ", jv[4 * v + c], " but skin ", node.skin,
                      " has only ", sj.size(), " joints");
            infl[base + v].push_back({sj[jv[4 * v + c]], w});
            if (to_bind) {
              const Mat4& x = joint_to_bind[node.skin][jv[4 * v + c]];
              for (int r = 0; r < 16; ++r) blend[v][r] += double(w) * x[r];
              blend_sum[v] += w;
            }
          }
      }
      for (std::size_t v = 0; v < blend.size(); ++v) {
        if (!(blend_sum[v] > 0.0)) continue;  // no weight: refused below
        float* q = &pos[3 * (base + v)];
        const double x = q[0], y = q[1], z = q[2];
        const auto& b = blend[v];
        for (int r = 0; r < 3; ++r) {  // column-major: m[col * 4 + row]
          q[r] = static_cast<float>((b[r] * x + b[4 + r] * y + b[8 + r] * z + b[12 + r]) / blend_sum[v]);
          if (!std::isfinite(q[r]))
            rd.fail(what, " vertex ", v, " is not finite once brought into the bind space of skin ", ref_skin,
                    " (skin ", node.skin, "'s inverse bind matrices are extreme)");
        }
      }
      std::vector<std::uint32_t> idx;
      if (prim.indices >= 0) {
        idx = rd.uints(prim.indices, 1, what + " indices");
      } else {
        idx.resize(nv);
        for (std::size_t i = 0; i < nv; ++i) idx[i] = static_cast<std::uint32_t>(i);
      }
      for (std::uint32_t i : idx)
        if (i >= nv) rd.fail(what, " index ", i, " is out of range (", nv, " vertices)");
      auto tri = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        tris.push_back(static_cast<std::int32_t>(base + a));
        tris.push_back(static_cast<std::int32_t>(base + b));
        tris.push_back(static_cast<std::int32_t>(base + c));
      };
      if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
        for (std::size_t t = 0; t + 2 < idx.size(); t += 3) tri(idx[t], idx[t + 1], idx[t + 2]);
      } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        for (std::size_t t = 0; t + 2 < idx.size(); ++t)
          t % 2 ? tri(idx[t + 1], idx[t], idx[t + 2]) : tri(idx[t], idx[t + 1], idx[t + 2]);
      } else {
        for (std::size_t t = 1; t + 1 < idx.size(); ++t) tri(idx[0], idx[t], idx[t + 1]);
      }
      ch.primitives.push_back({node.mesh, static_cast<std::int32_t>(pi), n,
                               node.name.empty() ? "Node_" + std::to_string(n) : node.name, base,
                               static_cast<std::int64_t>(nv), skin_to_bind[node.skin]});
    }
  }
  if (ch.primitives.empty() && !no_skin) rd.fail("no skinned mesh: no node has both a mesh with triangles and a skin");
  const std::int64_t nfile = static_cast<std::int64_t>(pos.size() / 3);
  for (std::int64_t v = 0; v < nfile; ++v) {
    double sum = 0.0;
    for (const auto& [j, w] : infl[v]) sum += w;
    if (!(sum > 0.0)) rd.fail("file vertex ", v, " has no non-zero skin weight");
  }

  if (!no_skin) {
    weld_into(ch, pos, infl, tris, opt.weld_tolerance);
    ch.mesh.validate(J, path.c_str());
  }

  // Animations, sampled per frame.
  if (opt.load_clips) {
    GATCORE_CHECK(opt.clip_fps > 0.0f, "clip_fps must be positive, got ", opt.clip_fps);
    for (std::size_t ai = 0; ai < model.animations.size(); ++ai) {
      const auto& anim = model.animations[ai];
      std::vector<Channel> channels;
      float duration = 0.0f;
      for (const auto& c : anim.channels) {
        if (c.target_node < 0 || c.target_node >= num_nodes || joint_of_node[c.target_node] < 0) continue;
        int path_id = c.target_path == "translation" ? 0 : c.target_path == "rotation" ? 1 : c.target_path == "scale" ? 2 : -1;
        if (path_id < 0) continue;
        if (c.sampler < 0 || c.sampler >= static_cast<int>(anim.samplers.size()))
          rd.fail("animation ", ai, " channel references missing sampler ", c.sampler);
        const auto& s = anim.samplers[c.sampler];
        const std::string what = "animation '" + anim.name + "' sampler " + std::to_string(c.sampler);
        Channel ch_;
        ch_.joint = joint_of_node[c.target_node];
        ch_.path = path_id;
        ch_.comps = path_id == 1 ? 4 : 3;
        ch_.interp = s.interpolation == "STEP" ? 1 : s.interpolation == "CUBICSPLINE" ? 2 : 0;
        ch_.times = rd.floats(s.input, 1, what + " input");
        // glTF: key times start at 0 or later and increase (equal neighbours
        // are let through: some exporters write them; floats() has refused
        // what is not finite).
        for (std::size_t k = 0; k < ch_.times.size(); ++k)
          if (!(ch_.times[k] >= (k ? ch_.times[k - 1] : 0.0f)))
            rd.fail(what, " input: key time ", k, " is ", ch_.times[k],
                    k ? detail::cat(" after ", ch_.times[k - 1]) : std::string(), " (times must be >= 0 and increasing)");
        ch_.values = rd.floats(s.output, ch_.comps, what + " output");
        const std::size_t need = ch_.times.size() * (ch_.interp == 2 ? 3 : 1) * ch_.comps;
        if (ch_.values.size() < need)
          rd.fail(what, " has ", ch_.values.size() / ch_.comps, " output values for ", ch_.times.size(), " key times");
        if (!ch_.times.empty()) duration = std::max(duration, ch_.times.back());
        channels.push_back(std::move(ch_));
      }
      if (channels.empty()) continue;
      Clip clip;
      clip.name = anim.name.empty() ? "animation" + std::to_string(ai) : anim.name;
      clip.fps = opt.clip_fps;
      const int frames = clip_frame_count(duration, opt.clip_fps, sk.num_joints(),
                                          path + ": animation '" + clip.name + "'");
      for (int f = 0; f < frames; ++f) {
        Pose p = rest_pose(sk);
        for (const auto& c : channels) sample(c, static_cast<float>(f) / opt.clip_fps, p.local[c.joint]);
        clip.frames.push_back(std::move(p));
      }
      ch.clips.push_back(std::move(clip));
    }
  }
  return ch;
}

namespace gltf_util {

std::vector<float> read_floats(const tinygltf::Model& m, int accessor, int comps, const std::string& what,
                               const std::string& file) {
  const Reader rd{m, file};
  return rd.floats(accessor, comps, what);
}

}  // namespace gltf_util

}  // namespace gatcore::character
