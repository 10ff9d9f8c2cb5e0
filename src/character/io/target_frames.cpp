#include "gatcore/character/io/target_frames.hpp"

#include <cmath>
#include <map>
#include <sstream>

#include "gatcore/character/io/bake.hpp"
#include "gatcore/error.hpp"
#include "src/character/io/gltf_util.hpp"

namespace gatcore::character {

namespace {

// File-vertex positions ([3 * file vertices]) averaged into welded vertices.
std::vector<float> to_welded(const Character& ch, const std::vector<double>& file_xyz) {
  const std::int64_t n = ch.mesh.num_vertices();
  std::vector<double> sum(static_cast<std::size_t>(3 * n), 0.0);
  std::vector<int> count(static_cast<std::size_t>(n), 0);
  const std::size_t nfile = ch.welded_from_file.empty() ? std::size_t(n) : ch.welded_from_file.size();
  for (std::size_t i = 0; i < nfile; ++i) {
    const std::int32_t v = ch.welded_from_file.empty() ? std::int32_t(i) : ch.welded_from_file[i];
    for (int c = 0; c < 3; ++c) sum[3 * std::size_t(v) + c] += file_xyz[3 * i + c];
    ++count[std::size_t(v)];
  }
  std::vector<float> out(sum.size());
  for (std::int64_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c)
      out[3 * v + c] = count[v] ? float(sum[3 * v + c] / count[v]) : ch.mesh.positions[3 * v + c];
  return out;
}

std::string joined(const std::vector<std::string>& paths) {
  std::string s;
  for (const std::string& p : paths) s += (s.empty() ? "" : ", ") + p;
  return s;
}

}  // namespace

TargetFrames read_point_cache_frames(const Character& ch, const std::vector<std::string>& paths) {
  GATCORE_CHECK(!paths.empty(), ch.name, ": no point cache given");
  // A character built in memory (procedural) has no file: its vertices are the points.
  const std::int64_t nfile = ch.welded_from_file.empty() ? ch.mesh.num_vertices() : ch.num_file_vertices();
  GATCORE_CHECK(nfile > 0, ch.name, ": the character has no vertices to match a point cache against");
  std::vector<PointCache> caches;
  std::int64_t total = 0;
  for (const std::string& p : paths) {
    caches.push_back(read_point_cache(p));
    total += caches.back().num_points;
  }
  const std::string what = joined(paths);
  GATCORE_CHECK(total == nfile, what, ": ", total, " points", paths.size() > 1 ? " in all" : "", ", but '", ch.name,
                "' has ", nfile, " file vertices (the points of every primitive, concatenated",
                paths.size() > 1 ? ", one cache per mesh or primitive in the file's order)" : ")");
  if (paths.size() > 1) {
    // Each cache must cover whole primitives: its first point starts one.
    std::int64_t first = 0;
    for (std::size_t k = 0; k < caches.size(); ++k) {
      bool starts = first == 0;
      for (const SourcePrimitive& sp : ch.primitives) starts = starts || sp.first_vertex == first;
      GATCORE_CHECK(starts, paths[k], ": starts at file vertex ", first, ", which is inside a primitive of ", ch.name,
                    " (one cache per mesh or primitive, in the file's order)");
      first += caches[k].num_points;
    }
  }
  const std::size_t S = caches[0].samples.size();
  GATCORE_CHECK(S > 0, paths[0], ": no samples");
  for (std::size_t k = 0; k < caches.size(); ++k) {
    GATCORE_CHECK(caches[k].samples.size() == S, paths[k], ": ", caches[k].samples.size(), " samples, ", paths[0],
                  " has ", S);
    GATCORE_CHECK(caches[k].start_frame == caches[0].start_frame && caches[k].sample_rate == caches[0].sample_rate,
                  paths[k], ": start frame / sample rate ", caches[k].start_frame, " / ", caches[k].sample_rate,
                  " differ from ", paths[0], "'s ", caches[0].start_frame, " / ", caches[0].sample_rate);
  }
  GATCORE_CHECK(std::isfinite(caches[0].start_frame) && std::isfinite(caches[0].sample_rate) &&
                    caches[0].sample_rate > 0.0f,
                paths[0], ": start frame ", caches[0].start_frame, " / sample rate ", caches[0].sample_rate,
                " (the sample rate must be positive)");
  TargetFrames t;
  t.source = what;
  t.start_frame = caches[0].start_frame;
  t.frame_step = caches[0].sample_rate;
  std::vector<double> file(static_cast<std::size_t>(3 * nfile));
  for (std::size_t s = 0; s < S; ++s) {
    std::size_t o = 0;
    for (std::size_t k = 0; k < caches.size(); ++k)
      for (std::size_t i = 0; i < caches[k].samples[s].size(); ++i) {
        const float x = caches[k].samples[s][i];
        GATCORE_CHECK(std::isfinite(x), paths[k], ": sample ", s, " point ", i / 3, " is not finite");
        file[o++] = x;
      }
    t.positions.push_back(to_welded(ch, file));
  }
  return t;
}

TargetFrames read_morph_target_frames(const Character& ch, const std::string& path, const std::string& animation) {
  const tinygltf::Model m = gltf_util::read_model(path);
  // The animation: by name, else "deform", else the only one animating weights.
  int ai = -1;
  std::vector<int> with_weights;
  for (std::size_t a = 0; a < m.animations.size(); ++a) {
    bool w = false;
    for (const auto& c : m.animations[a].channels) w = w || c.target_path == "weights";
    if (w) with_weights.push_back(int(a));
    if (!animation.empty() && m.animations[a].name == animation) ai = int(a);
  }
  if (animation.empty())
    for (int a : with_weights)
      if (m.animations[std::size_t(a)].name == "deform") ai = a;
  if (animation.empty() && ai < 0 && with_weights.size() == 1) ai = with_weights[0];
  GATCORE_CHECK(ai >= 0, path, ": ",
                animation.empty() ? (with_weights.empty() ? std::string("no animation of morph weights")
                                                          : std::to_string(with_weights.size()) +
                                                                " animations of morph weights and none named 'deform'")
                                  : "no animation named '" + animation + "'");
  const tinygltf::Animation& anim = m.animations[std::size_t(ai)];
  const std::string aname = "animation '" + anim.name + "'";

  // Per node: the target index shown at each frame.
  std::map<int, std::vector<int>> frame_targets;
  for (const auto& c : anim.channels) {
    if (c.target_path != "weights") continue;
    GATCORE_CHECK(c.target_node >= 0 && c.target_node < int(m.nodes.size()) && m.nodes[c.target_node].mesh >= 0 &&
                      c.sampler >= 0 && c.sampler < int(anim.samplers.size()),
                  path, ": ", aname, " animates the weights of node ", c.target_node, ", which has no mesh");
    const tinygltf::Mesh& mesh = m.meshes.at(std::size_t(m.nodes[c.target_node].mesh));
    const std::size_t T = mesh.primitives.empty() ? 0 : mesh.primitives[0].targets.size();
    GATCORE_CHECK(T > 0, path, ": node ", c.target_node, "'s mesh has no morph targets");
    const auto& s = anim.samplers[std::size_t(c.sampler)];
    const std::string what = aname + " sampler " + std::to_string(c.sampler);
    const std::vector<float> times = gltf_util::read_floats(m, s.input, 1, what + " input", path);
    const std::vector<float> w = gltf_util::read_floats(m, s.output, 1, what + " output", path);
    GATCORE_CHECK(s.interpolation != "CUBICSPLINE" && w.size() == times.size() * T, path, ": ", what, " has ",
                  w.size(), " weights for ", times.size(), " keys x ", T,
                  " targets (a per-frame morph animation has one weight per target and key, LINEAR or STEP)");
    std::vector<int> shown;
    for (std::size_t k = 0; k < times.size(); ++k) {
      int on = -1;
      for (std::size_t t = 0; t < T; ++t) {
        const double def = t < mesh.weights.size() ? mesh.weights[t] : 0.0;
        const float x = w[k * T + t];
        if (x == 1.0f && def == 0.0) {
          GATCORE_CHECK(on < 0, path, ": ", what, " key ", k, " shows targets ", on, " and ", t,
                        " at once (not one frame per key)");
          on = int(t);
        } else {
          GATCORE_CHECK(std::abs(x - def) <= 1e-6, path, ": ", what, " key ", k, " gives target ", t, " weight ", x,
                        " (not one frame per key: a frame's target has weight 1, the others their defaults)");
        }
      }
      GATCORE_CHECK(on >= 0, path, ": ", what, " key ", k, " shows no target at weight 1");
      // gat deform ends with a key that holds the last frame.
      if (!shown.empty() && shown.back() == on && k + 1 == times.size()) break;
      shown.push_back(on);
    }
    frame_targets[c.target_node] = std::move(shown);
  }
  GATCORE_CHECK(!frame_targets.empty(), path, ": ", aname, " animates no morph weights");
  const std::size_t F = frame_targets.begin()->second.size();
  for (const auto& [node, shown] : frame_targets)
    GATCORE_CHECK(shown.size() == F, path, ": ", aname, " shows ", shown.size(), " frames on node ", node, " and ", F,
                  " on node ", frame_targets.begin()->first);

  std::vector<std::vector<double>> file(F, std::vector<double>(static_cast<std::size_t>(3 * ch.num_file_vertices())));
  for (const SourcePrimitive& sp : ch.primitives) {
    const std::string where = path + ": node " + std::to_string(sp.node) + " primitive " + std::to_string(sp.primitive);
    GATCORE_CHECK(sp.node >= 0 && sp.node < int(m.nodes.size()) && m.nodes[sp.node].mesh >= 0, where,
                  ": the file does not match ", ch.name, " (no such mesh node)");
    const auto it = frame_targets.find(sp.node);
    GATCORE_CHECK(it != frame_targets.end(), where, ": ", aname, " does not animate this skinned mesh's morph weights");
    const tinygltf::Mesh& mesh = m.meshes.at(std::size_t(m.nodes[sp.node].mesh));
    GATCORE_CHECK(sp.primitive >= 0 && sp.primitive < int(mesh.primitives.size()), where,
                  ": the file does not match ", ch.name, " (no such primitive)");
    const tinygltf::Primitive& prim = mesh.primitives[std::size_t(sp.primitive)];
    const auto pos = prim.attributes.find("POSITION");
    GATCORE_CHECK(pos != prim.attributes.end(), where, " has no POSITION");
    const std::vector<float> base = gltf_util::read_floats(m, pos->second, 3, "POSITION", where);
    GATCORE_CHECK(static_cast<std::int64_t>(base.size()) == 3 * sp.num_vertices, where, " has ", base.size() / 3,
                  " vertices, ", ch.name, " ", sp.num_vertices, " (a different character?)");
    for (std::size_t f = 0; f < F; ++f) {
      const int t = it->second[f];
      GATCORE_CHECK(t < int(prim.targets.size()), where, " has no morph target ", t);
      const auto d = prim.targets[std::size_t(t)].find("POSITION");
      GATCORE_CHECK(d != prim.targets[std::size_t(t)].end(), where, " morph target ", t, " has no POSITION");
      const std::vector<float> delta =
          gltf_util::read_floats(m, d->second, 3, "morph target " + std::to_string(t) + " POSITION", where);
      GATCORE_CHECK(delta.size() == base.size(), where, " morph target ", t, " has ", delta.size() / 3,
                    " deltas for ", base.size() / 3, " vertices");
      for (std::size_t i = 0; i < base.size(); ++i)
        file[f][3 * static_cast<std::size_t>(sp.first_vertex) + i] = double(base[i]) + double(delta[i]);
      if (sp.to_bind != mat4_identity()) {  // the primitive's own space -> the character's
        const Mat4& x = sp.to_bind;
        for (std::size_t i = 0; i < base.size(); i += 3) {
          double* q = &file[f][3 * static_cast<std::size_t>(sp.first_vertex) + i];
          const double a = q[0], b = q[1], c = q[2];
          for (int r = 0; r < 3; ++r) q[r] = x[r] * a + x[4 + r] * b + x[8 + r] * c + x[12 + r];
        }
      }
    }
  }
  TargetFrames out;
  out.source = path;
  // Frames are numbered by key (gat deform: key k at k / fps, the clip's
  // rate; with --frames A:B frame 0 is the motion's frame A: the dataset's
  // frame map says so).
  for (std::size_t f = 0; f < F; ++f) out.positions.push_back(to_welded(ch, file[f]));
  return out;
}

TargetFrames read_target_frames(const Character& ch, const std::string& spec, const std::string& animation) {
  const auto ends = [&](const char* e) {
    const std::string s(e);
    return spec.size() >= s.size() && spec.compare(spec.size() - s.size(), s.size(), s) == 0;
  };
  if (ends(".glb") || ends(".gltf")) return read_morph_target_frames(ch, spec, animation);
  if (ends(".pc2")) {
    std::vector<std::string> paths;
    std::stringstream ss(spec);
    std::string p;
    while (std::getline(ss, p, ','))
      if (!p.empty()) paths.push_back(p);
    return read_point_cache_frames(ch, paths);
  }
  throw InvalidArgument(spec + ": unknown target file type (expected .pc2, a comma-separated list of .pc2, .glb or .gltf)");
}

}  // namespace gatcore::character
