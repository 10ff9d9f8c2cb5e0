#include "gatcore/character/io/bake.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <cctype>
#include <limits>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "gatcore/character/rig/pose.hpp"
#include "gatcore/atomic_file.hpp"
#include "gatcore/error.hpp"
#include "src/character/io/gltf_util.hpp"

namespace gatcore::character {

std::vector<float> file_vertex_positions(const Character& ch, const std::vector<float>& welded) {
  GATCORE_CHECK(static_cast<std::int64_t>(welded.size()) == 3 * ch.mesh.num_vertices(), ch.name, ": ",
                welded.size() / 3, " positions for ", ch.mesh.num_vertices(), " welded vertices");
  std::vector<float> out(3 * ch.welded_from_file.size());
  for (std::size_t i = 0; i < ch.welded_from_file.size(); ++i)
    for (int c = 0; c < 3; ++c) out[3 * i + c] = welded[3 * static_cast<std::size_t>(ch.welded_from_file[i]) + c];
  return out;
}

namespace {

int append_floats(tinygltf::Model& m, const std::vector<float>& v, int type, std::size_t count) {
  return gltf_util::append_accessor(m, v.data(), v.size() * sizeof(float), TINYGLTF_COMPONENT_TYPE_FLOAT, type, count);
}

}  // namespace

void save_gltf_morph_animation(const std::string& source_path, const Character& ch, const BakedFrames& frames,
                               const std::string& out_path) {
  const std::size_t F = frames.positions.size();
  GATCORE_CHECK(F > 0, out_path, ": no frames to bake");
  GATCORE_CHECK(std::isfinite(frames.fps) && frames.fps > 0.0f, out_path, ": fps must be positive, got ", frames.fps);
  const std::int64_t nw = ch.mesh.num_vertices();
  for (std::size_t f = 0; f < F; ++f) {
    GATCORE_CHECK(static_cast<std::int64_t>(frames.positions[f].size()) == 3 * nw, out_path, ": frame ", f, " has ",
                  frames.positions[f].size() / 3, " positions for ", nw, " vertices");
    for (std::size_t i = 0; i < frames.positions[f].size(); ++i)
      GATCORE_CHECK(std::isfinite(frames.positions[f][i]), out_path, ": frame ", f, " vertex ", i / 3,
                    " is not finite");
  }
  const std::int32_t J = ch.skeleton.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(ch.joint_nodes.size()) == J, out_path,
                ": the character has no file node per joint (not loaded from a glTF file)");
  tinygltf::Model model = gltf_util::read_model(source_path);
  const int num_nodes = static_cast<int>(model.nodes.size());

  // Skinned primitives by node; a mesh instanced by several of them gets a
  // copy per further node (their targets differ).
  std::map<int, std::vector<const SourcePrimitive*>> by_node;
  for (const SourcePrimitive& sp : ch.primitives) {
    GATCORE_CHECK(sp.node >= 0 && sp.node < num_nodes && sp.mesh >= 0 &&
                      sp.mesh < static_cast<int>(model.meshes.size()) && model.nodes[sp.node].mesh == sp.mesh &&
                      sp.primitive >= 0 &&
                      sp.primitive < static_cast<int>(model.meshes[sp.mesh].primitives.size()),
                  source_path, ": does not match the character (node ", sp.node, ", mesh ", sp.mesh, ", primitive ",
                  sp.primitive, ")");
    by_node[sp.node].push_back(&sp);
  }
  std::set<int> meshes_used;
  std::vector<float> times(F + 1);
  // One more key holding the last frame, so it shows for a whole frame too.
  for (std::size_t f = 0; f <= F; ++f) times[f] = static_cast<float>(f) / frames.fps;
  const int time_acc = append_floats(model, times, TINYGLTF_TYPE_SCALAR, F + 1);
  model.accessors[time_acc].minValues = {0.0};
  model.accessors[time_acc].maxValues = {times.back()};
  tinygltf::Animation anim;
  anim.name = frames.name;

  for (const auto& [node, prims] : by_node) {
    int mesh_id = model.nodes[node].mesh;
    if (!meshes_used.insert(mesh_id).second) {
      model.meshes.push_back(model.meshes[mesh_id]);
      mesh_id = static_cast<int>(model.meshes.size()) - 1;
      model.nodes[node].mesh = mesh_id;
    }
    tinygltf::Mesh& mesh = model.meshes[mesh_id];
    // Existing targets (e.g. facial shapes) keep their places and default weights.
    const std::size_t existing = mesh.primitives.empty() ? 0 : mesh.primitives[0].targets.size();
    for (std::size_t p = 0; p < mesh.primitives.size(); ++p)
      GATCORE_CHECK(mesh.primitives[p].targets.size() == existing, source_path, ": mesh ", mesh_id,
                    " has primitives with different numbers of morph targets");
    std::map<int, const SourcePrimitive*> ours;
    for (const SourcePrimitive* sp : prims) ours[sp->primitive] = sp;
    for (std::size_t p = 0; p < mesh.primitives.size(); ++p) {
      tinygltf::Primitive& prim = mesh.primitives[p];
      const auto pos = prim.attributes.find("POSITION");
      GATCORE_CHECK(pos != prim.attributes.end(), source_path, ": mesh ", mesh_id, " primitive ", p,
                    " has no POSITION");
      const std::size_t count = model.accessors.at(static_cast<std::size_t>(pos->second)).count;
      const auto it = ours.find(static_cast<int>(p));
      if (it == ours.end()) {
        // Not part of the character (e.g. not triangles): targets that do nothing.
        const int zero = gltf_util::append_vec3(model, std::vector<float>(3 * count, 0.0f));
        for (std::size_t f = 0; f < F; ++f) prim.targets.push_back({{"POSITION", zero}});
        continue;
      }
      const SourcePrimitive& sp = *it->second;
      const std::vector<float> base = gltf_util::read_floats(
          model, pos->second, 3, "mesh " + std::to_string(mesh_id) + " primitive " + std::to_string(p) + " POSITION",
          source_path);
      GATCORE_CHECK(static_cast<std::int64_t>(count) == sp.num_vertices &&
                        sp.first_vertex + sp.num_vertices <= ch.num_file_vertices(),
                    source_path, ": mesh ", mesh_id, " primitive ", p, " has ", count, " vertices, the character ",
                    sp.num_vertices);
      // With the joints at their bind transforms a viewer shows the
      // primitive's positions through to_bind: targets go back through it.
      const bool own_space = sp.to_bind != mat4_identity();
      const Mat4 from_bind = own_space ? inverse(sp.to_bind) : mat4_identity();
      for (std::size_t f = 0; f < F; ++f) {
        const std::vector<float>& w = frames.positions[f];
        std::vector<float> d(3 * count);
        for (std::size_t i = 0; i < count; ++i) {
          const std::size_t v = static_cast<std::size_t>(ch.welded_from_file[static_cast<std::size_t>(sp.first_vertex) + i]);
          Vec3 t{w[3 * v], w[3 * v + 1], w[3 * v + 2]};
          if (own_space) t = transform_point(from_bind, t);
          for (int c = 0; c < 3; ++c) d[3 * i + c] = t[c] - base[3 * i + c];
        }
        prim.targets.push_back({{"POSITION", gltf_util::append_vec3(model, d)}});
      }
    }
    const std::size_t T = existing + F;
    std::vector<double> defaults = mesh.weights;
    defaults.resize(existing, 0.0);
    mesh.weights = defaults;
    mesh.weights.resize(T, 0.0);
    // Key k: the existing targets at their defaults, ours one-hot at frame min(k, F - 1).
    std::vector<float> w((F + 1) * T, 0.0f);
    for (std::size_t k = 0; k <= F; ++k) {
      for (std::size_t e = 0; e < existing; ++e) w[k * T + e] = static_cast<float>(defaults[e]);
      w[k * T + existing + std::min(k, F - 1)] = 1.0f;
    }
    tinygltf::AnimationSampler s;
    s.input = time_acc;
    s.output = append_floats(model, w, TINYGLTF_TYPE_SCALAR, w.size());
    s.interpolation = "STEP";
    anim.samplers.push_back(s);
    tinygltf::AnimationChannel c;
    c.sampler = static_cast<int>(anim.samplers.size()) - 1;
    c.target_node = node;
    c.target_path = "weights";
    anim.channels.push_back(c);
  }

  // Joints held at their bind transforms: skinning becomes the identity, so
  // the viewer shows the baked positions themselves.
  // Constant keys at the morph keys' times, so the clip has one duration.
  const Pose bind = bind_pose(ch.skeleton);
  for (std::int32_t j = 0; j < J; ++j) {
    const int node = ch.joint_nodes[j];
    GATCORE_CHECK(node >= 0 && node < num_nodes, source_path, ": joint '", ch.skeleton.names[j],
                  "' has no node in the file");
    // glTF animates only TRS nodes: a joint given by a matrix gets the same
    // transform as TRS (joints carry no shear).
    tinygltf::Node& jn = model.nodes[static_cast<std::size_t>(node)];
    if (jn.matrix.size() == 16) {
      const Transform rest = to_transform(gltf_util::node_matrix(jn));
      jn.matrix.clear();
      jn.translation.assign(rest.translation.begin(), rest.translation.end());
      jn.rotation.assign(rest.rotation.begin(), rest.rotation.end());
      jn.scale.assign(rest.scale.begin(), rest.scale.end());
    }
    const Transform& t = bind.local[j];
    std::vector<float> tr, rot, sc;
    for (std::size_t k = 0; k <= F; ++k) {
      tr.insert(tr.end(), t.translation.begin(), t.translation.end());
      rot.insert(rot.end(), t.rotation.begin(), t.rotation.end());
      sc.insert(sc.end(), t.scale.begin(), t.scale.end());
    }
    const std::pair<const char*, const std::vector<float>*> parts[] = {{"translation", &tr}, {"rotation", &rot}, {"scale", &sc}};
    for (const auto& [path, values] : parts) {
      tinygltf::AnimationSampler s;
      s.input = time_acc;
      s.output = append_floats(model, *values, path == std::string("rotation") ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3,
                               F + 1);
      s.interpolation = "STEP";
      anim.samplers.push_back(s);
      tinygltf::AnimationChannel c;
      c.sampler = static_cast<int>(anim.samplers.size()) - 1;
      c.target_node = node;
      c.target_path = path;
      anim.channels.push_back(c);
    }
  }
  model.animations.push_back(anim);
  gltf_util::write_model_atomic(model, out_path);
}

namespace {

template <class T>
void put(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // x86 / ARM: little endian, as the format wants
  s.append(b, sizeof(T));
}

template <class T>
T get(const std::string& s, std::size_t at) {
  T v;
  std::memcpy(&v, s.data() + at, sizeof(T));
  return v;
}

constexpr std::size_t kHeader = 12 + 4 + 4 + 4 + 4 + 4;

}  // namespace

void write_point_cache(const std::string& path, const PointCache& pc) {
  GATCORE_CHECK(pc.num_points > 0 && !pc.samples.empty(), path, ": a point cache needs points and samples (got ",
                pc.num_points, " points, ", pc.samples.size(), " samples)");
  GATCORE_CHECK(std::isfinite(pc.start_frame) && std::isfinite(pc.sample_rate) && pc.sample_rate > 0.0f, path,
                ": bad start frame ", pc.start_frame, " or sample rate ", pc.sample_rate);
  std::string out("POINTCACHE2\0", 12);
  put<std::int32_t>(out, 1);
  put<std::int32_t>(out, pc.num_points);
  put<float>(out, pc.start_frame);
  put<float>(out, pc.sample_rate);
  put<std::int32_t>(out, static_cast<std::int32_t>(pc.samples.size()));
  for (std::size_t s = 0; s < pc.samples.size(); ++s) {
    GATCORE_CHECK(static_cast<std::int64_t>(pc.samples[s].size()) == 3 * std::int64_t{pc.num_points}, path,
                  ": sample ", s, " has ", pc.samples[s].size(), " floats for ", pc.num_points, " points");
    for (float v : pc.samples[s]) {
      GATCORE_CHECK(std::isfinite(v), path, ": sample ", s, " holds a non-finite value");
      put<float>(out, v);
    }
  }
  write_file_atomic(path, out);
}

PointCache read_point_cache(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  GATCORE_CHECK(is.good(), path, ": cannot open file");
  const std::string b((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  GATCORE_CHECK(b.size() >= kHeader, path, ": truncated: ", b.size(), " bytes, a .pc2 header has ", kHeader);
  GATCORE_CHECK(b.compare(0, 12, std::string("POINTCACHE2\0", 12)) == 0, path,
                ": not a point cache (no POINTCACHE2 signature)");
  GATCORE_CHECK(get<std::int32_t>(b, 12) == 1, path, ": unsupported .pc2 version ", get<std::int32_t>(b, 12));
  PointCache pc;
  pc.num_points = get<std::int32_t>(b, 16);
  pc.start_frame = get<float>(b, 20);
  pc.sample_rate = get<float>(b, 24);
  const std::int32_t n = get<std::int32_t>(b, 28);
  // Counts are file-provided: compared with the payload by division, so no
  // product can wrap around, and nothing is allocated before they match.
  GATCORE_CHECK(pc.num_points > 0 && n > 0, path, ": ", pc.num_points, " points x ", n,
                " samples (a point cache needs at least one of each)");
  GATCORE_CHECK(std::isfinite(pc.start_frame) && std::isfinite(pc.sample_rate) && pc.sample_rate > 0.0f, path,
                ": bad start frame ", pc.start_frame, " or sample rate ", pc.sample_rate);
  const std::uint64_t payload = b.size() - kHeader, per_sample = 12ull * std::uint64_t(pc.num_points);
  GATCORE_CHECK(payload % per_sample == 0 && payload / per_sample == std::uint64_t(n), path, ": ", b.size(),
                " bytes, but ", pc.num_points, " points x ", n, " samples need ", kHeader, " + 12 x ", pc.num_points,
                " x ", n, " (truncated or corrupted)");
  pc.samples.resize(static_cast<std::size_t>(n));
  for (std::int32_t s = 0; s < n; ++s) {
    auto& v = pc.samples[std::size_t(s)];
    v.resize(3 * static_cast<std::size_t>(pc.num_points));
    std::memcpy(v.data(), b.data() + kHeader + per_sample * std::uint64_t(s), per_sample);
    for (std::size_t k = 0; k < v.size(); ++k)
      GATCORE_CHECK(std::isfinite(v[k]), path, ": sample ", s, " point ", k / 3, " holds a non-finite value");
  }
  return pc;
}

std::vector<ObjectPointCache> object_point_caches(const Character& ch, const BakedFrames& frames, UpAxis up,
                                                  float start_frame) {
  GATCORE_CHECK(!frames.positions.empty(), ch.name, ": no frames to write as point caches");
  std::vector<ObjectPointCache> out;
  std::map<std::string, std::size_t> index;  // object -> out
  std::vector<std::vector<const SourcePrimitive*>> prims;
  for (const SourcePrimitive& sp : ch.primitives) {
    const std::string key = sp.object.empty() ? "node" + std::to_string(sp.node) : sp.object;
    const auto [it, fresh] = index.emplace(key + "#" + std::to_string(sp.node), out.size());
    if (fresh) {
      out.push_back({key, {}});
      prims.emplace_back();
    }
    prims[it->second].push_back(&sp);
  }
  for (std::size_t o = 0; o < out.size(); ++o) {
    PointCache& pc = out[o].cache;
    std::int64_t n = 0;
    for (const SourcePrimitive* sp : prims[o]) n += sp->num_vertices;
    GATCORE_CHECK(n > 0 && n <= std::numeric_limits<std::int32_t>::max(), ch.name, ": object ", out[o].object, " has ",
                  n, " vertices");
    pc.num_points = static_cast<std::int32_t>(n);
    pc.start_frame = start_frame;
    pc.sample_rate = 1.0f;
    for (const std::vector<float>& w : frames.positions) {
      GATCORE_CHECK(static_cast<std::int64_t>(w.size()) == 3 * ch.mesh.num_vertices(), ch.name, ": a frame has ",
                    w.size() / 3, " positions for ", ch.mesh.num_vertices(), " vertices");
      std::vector<float> s;
      s.reserve(3 * static_cast<std::size_t>(n));
      for (const SourcePrimitive* sp : prims[o])
        for (std::int64_t i = 0; i < sp->num_vertices; ++i) {
          const float* p = &w[3 * static_cast<std::size_t>(ch.welded_from_file[static_cast<std::size_t>(sp->first_vertex + i)])];
          if (up == UpAxis::z) {
            s.insert(s.end(), {p[0], -p[2], p[1]});
          } else {
            s.insert(s.end(), {p[0], p[1], p[2]});
          }
        }
      pc.samples.push_back(std::move(s));
    }
  }
  return out;
}

std::vector<std::string> object_point_cache_paths(const std::string& path, const std::vector<ObjectPointCache>& caches) {
  if (caches.size() == 1) return {path};
  std::string stem = path;
  if (stem.size() > 4 && stem.compare(stem.size() - 4, 4, ".pc2") == 0) stem.resize(stem.size() - 4);
  std::vector<std::string> paths;
  std::set<std::string> seen;
  for (std::size_t o = 0; o < caches.size(); ++o) {
    std::string name = caches[o].object;
    for (char& c : name)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') c = '_';
    std::string p = stem + "_" + name + ".pc2";
    if (!seen.insert(p).second) {
      p = stem + "_" + name + "_" + std::to_string(o) + ".pc2";
      seen.insert(p);
    }
    paths.push_back(p);
  }
  return paths;
}

std::vector<std::string> write_object_point_caches(const std::string& path, const std::vector<ObjectPointCache>& caches) {
  const std::vector<std::string> paths = object_point_cache_paths(path, caches);
  std::size_t written = 0;
  try {
    for (; written < caches.size(); ++written) write_point_cache(paths[written], caches[written].cache);
  } catch (...) {
    for (std::size_t i = 0; i < written; ++i) std::remove(paths[i].c_str());
    throw;
  }
  return paths;
}

}  // namespace gatcore::character
