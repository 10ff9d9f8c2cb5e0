// save_gltf_character: a character that exists only in memory (procedural
// characters) as a glTF file other tools, and gat's own commands, can read.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/error.hpp"
#include "src/character/io/gltf_util.hpp"

namespace gatcore::character {

namespace {

bool is_identity(const Mat4& m) {
  const Mat4 id = mat4_identity();
  for (int i = 0; i < 16; ++i)
    if (std::abs(m[i] - id[i]) > 1e-7f) return false;
  return true;
}

}  // namespace

void save_gltf_character(const Character& ch, const std::string& out_path) {
  const Skeleton& sk = ch.skeleton;
  sk.validate(out_path.c_str());
  const std::int32_t J = sk.num_joints();
  ch.mesh.validate(J, out_path.c_str());
  GATCORE_CHECK(J > 0 && J <= 65536, out_path, ": cannot write a skin of ", J, " joints");
  const std::int64_t n = ch.mesh.num_vertices();
  GATCORE_CHECK(n > 0 && ch.mesh.num_triangles() > 0, out_path, ": the character has no triangles");

  tinygltf::Model m;
  m.asset.version = "2.0";
  m.asset.generator = "gatcore";
  m.buffers.emplace_back();
  tinygltf::Scene scene;
  scene.name = ch.name;

  // Node 0: the mesh; joints follow, with parent nodes for roots whose
  // root_parent is not the identity (e.g. an armature's scale).
  tinygltf::Node mesh_node;
  mesh_node.name = ch.name.empty() ? "character" : ch.name;
  mesh_node.mesh = 0;
  mesh_node.skin = 0;
  m.nodes.push_back(mesh_node);
  scene.nodes.push_back(0);
  std::vector<int> joint_node(static_cast<std::size_t>(J));
  for (std::int32_t j = 0; j < J; ++j) {
    tinygltf::Node node;
    node.name = sk.names[j];
    const Transform& t = sk.rest_local[j];
    node.translation = {t.translation[0], t.translation[1], t.translation[2]};
    node.rotation = {t.rotation[0], t.rotation[1], t.rotation[2], t.rotation[3]};
    node.scale = {t.scale[0], t.scale[1], t.scale[2]};
    joint_node[j] = static_cast<int>(m.nodes.size());
    m.nodes.push_back(node);
    if (sk.parents[j] >= 0) {
      m.nodes[joint_node[sk.parents[j]]].children.push_back(joint_node[j]);
    } else if (is_identity(sk.root_parent[j])) {
      scene.nodes.push_back(joint_node[j]);
    } else {
      tinygltf::Node holder;
      holder.name = sk.names[j] + "_parent";
      holder.matrix.assign(sk.root_parent[j].begin(), sk.root_parent[j].end());
      holder.children.push_back(joint_node[j]);
      scene.nodes.push_back(static_cast<int>(m.nodes.size()));
      m.nodes.push_back(holder);
    }
  }
  tinygltf::Skin skin;
  skin.joints = joint_node;
  std::vector<float> ibm(16 * static_cast<std::size_t>(J));
  for (std::int32_t j = 0; j < J; ++j) std::copy(sk.inverse_bind[j].begin(), sk.inverse_bind[j].end(), ibm.begin() + 16 * j);
  skin.inverseBindMatrices = gltf_util::append_accessor(m, ibm.data(), ibm.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                        TINYGLTF_TYPE_MAT4, static_cast<std::size_t>(J));
  m.skins.push_back(skin);

  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] = gltf_util::append_vec3(m, ch.mesh.positions);
  const std::vector<float> normals = vertex_normals(ch.mesh.positions, ch.mesh.triangles);
  prim.attributes["NORMAL"] = gltf_util::append_accessor(m, normals.data(), normals.size() * 4,
                                                         TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                                         static_cast<std::size_t>(n));
  std::vector<std::uint32_t> idx(ch.mesh.triangles.begin(), ch.mesh.triangles.end());
  prim.indices = gltf_util::append_accessor(m, idx.data(), idx.size() * 4, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                            TINYGLTF_TYPE_SCALAR, idx.size());
  const SkinWeights& w = ch.mesh.weights;
  const int sets = static_cast<int>((std::max<std::int64_t>(1, w.max_influences()) + 3) / 4);
  for (int set = 0; set < sets; ++set) {
    std::vector<std::uint16_t> js(4 * static_cast<std::size_t>(n), 0);
    std::vector<float> ws(4 * static_cast<std::size_t>(n), 0.0f);
    for (std::int64_t v = 0; v < n; ++v)
      for (int k = 0; k < 4; ++k) {
        const std::int64_t e = w.ptr[v] + 4 * set + k;
        if (e >= w.ptr[v + 1]) break;
        js[4 * v + k] = static_cast<std::uint16_t>(w.joint[e]);
        ws[4 * v + k] = w.weight[e];
      }
    prim.attributes["JOINTS_" + std::to_string(set)] = gltf_util::append_accessor(
        m, js.data(), js.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, static_cast<std::size_t>(n));
    prim.attributes["WEIGHTS_" + std::to_string(set)] = gltf_util::append_accessor(
        m, ws.data(), ws.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, static_cast<std::size_t>(n));
  }
  tinygltf::Mesh mesh;
  mesh.name = mesh_node.name;
  mesh.primitives.push_back(prim);
  m.meshes.push_back(mesh);
  // Clips: one animation each, a key per frame (linear), translation and
  // rotation of every joint (scale stays the rest scale).
  for (const Clip& clip : ch.clips) {
    if (clip.frames.empty()) continue;
    GATCORE_CHECK(std::isfinite(clip.fps) && clip.fps > 0.0f, out_path, ": clip '", clip.name, "' at ", clip.fps, " fps");
    const std::size_t F = clip.frames.size();
    std::vector<float> times(F);
    for (std::size_t f = 0; f < F; ++f) times[f] = static_cast<float>(f) / clip.fps;
    tinygltf::Animation anim;
    anim.name = clip.name;
    const int input = gltf_util::append_accessor(m, times.data(), F * 4, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                 TINYGLTF_TYPE_SCALAR, F);
    m.accessors[std::size_t(input)].minValues = {0.0};
    m.accessors[std::size_t(input)].maxValues = {double(times.back())};
    for (std::int32_t j = 0; j < J; ++j) {
      std::vector<float> tr(3 * F), rot(4 * F);
      for (std::size_t f = 0; f < F; ++f) {
        GATCORE_CHECK(static_cast<std::int32_t>(clip.frames[f].local.size()) == J, out_path, ": clip '", clip.name,
                      "' frame ", f, " has ", clip.frames[f].local.size(), " joint transforms for ", J, " joints");
        const Transform& t = clip.frames[f].local[std::size_t(j)];
        std::copy(t.translation.begin(), t.translation.end(), tr.begin() + 3 * std::ptrdiff_t(f));
        std::copy(t.rotation.begin(), t.rotation.end(), rot.begin() + 4 * std::ptrdiff_t(f));
      }
      for (int k = 0; k < 2; ++k) {
        tinygltf::AnimationSampler smp;
        smp.input = input;
        smp.interpolation = "LINEAR";
        smp.output = k == 0 ? gltf_util::append_accessor(m, tr.data(), tr.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                         TINYGLTF_TYPE_VEC3, F)
                            : gltf_util::append_accessor(m, rot.data(), rot.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                                         TINYGLTF_TYPE_VEC4, F);
        tinygltf::AnimationChannel ch_;
        ch_.sampler = static_cast<int>(anim.samplers.size());
        ch_.target_node = joint_node[std::size_t(j)];
        ch_.target_path = k == 0 ? "translation" : "rotation";
        anim.samplers.push_back(smp);
        anim.channels.push_back(ch_);
      }
    }
    m.animations.push_back(std::move(anim));
  }
  m.scenes.push_back(scene);
  m.defaultScene = 0;
  gltf_util::write_model_atomic(m, out_path);
}

}  // namespace gatcore::character
