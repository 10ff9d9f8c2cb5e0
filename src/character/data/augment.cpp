#include "gatcore/character/data/augment.hpp"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <unordered_map>

#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

using Influences = std::vector<std::vector<std::pair<std::int32_t, float>>>;  // per vertex: (joint, weight)

Influences unpack(const SkinWeights& w) {
  Influences out(static_cast<std::size_t>(w.num_vertices()));
  for (std::int64_t v = 0; v < w.num_vertices(); ++v)
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) out[std::size_t(v)].push_back({w.joint[k], w.weight[k]});
  return out;
}

// Sums duplicate joints, drops non-positive weights, sorts joints, keeps the
// top k and renormalises (limit_weights).
SkinWeights pack(const Influences& in, int max_influences) {
  SkinWeights w;
  w.ptr.assign(1, 0);
  for (const auto& row : in) {
    std::map<std::int32_t, double> sum;
    for (const auto& [j, x] : row) sum[j] += x;
    for (const auto& [j, x] : sum)
      if (x > 0) {
        w.joint.push_back(j);
        w.weight.push_back(static_cast<float>(x));
      }
    w.ptr.push_back(static_cast<std::int64_t>(w.joint.size()));
  }
  return limit_weights(w, max_influences);
}

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 vertex(const Mesh& m, std::int64_t v) {
  return {m.positions[3 * std::size_t(v)], m.positions[3 * std::size_t(v) + 1], m.positions[3 * std::size_t(v) + 2]};
}
Vec3 bind_head(const Skeleton& s, std::int32_t j) { return mat4_translation(inverse(s.inverse_bind[std::size_t(j)])); }

// The variant's file bookkeeping: one object, its vertices the welded ones;
// no clips (the source's do not fit an edited skeleton or mesh).
void reset_file_maps(Character& c) {
  c.welded_from_file.resize(std::size_t(c.mesh.num_vertices()));
  std::iota(c.welded_from_file.begin(), c.welded_from_file.end(), 0);
  SourcePrimitive p;
  p.object = c.primitives.empty() ? std::string("mesh") : c.primitives.front().object;
  p.num_vertices = c.mesh.num_vertices();
  c.primitives.assign(1, p);
  c.joint_nodes.assign(std::size_t(c.skeleton.num_joints()), -1);
  c.clips.clear();
}

void check(const Character& c, const char* what) {
  c.skeleton.validate(what);
  c.mesh.validate(c.skeleton.num_joints(), what);
}

// Inserts a joint at index `pos` (joints from pos on shift up by one).
void insert_joint(Character& c, std::int32_t pos, const std::string& name, std::int32_t parent, const Transform& rest,
                  const Mat4& inverse_bind) {
  Skeleton& s = c.skeleton;
  GATCORE_CHECK(parent < pos, "insert_joint: parent ", parent, " is not before ", pos);
  for (auto& p : s.parents)
    if (p >= pos) ++p;
  for (auto& j : c.mesh.weights.joint)
    if (j >= pos) ++j;
  s.names.insert(s.names.begin() + pos, name);
  s.parents.insert(s.parents.begin() + pos, parent);
  s.rest_local.insert(s.rest_local.begin() + pos, rest);
  s.inverse_bind.insert(s.inverse_bind.begin() + pos, inverse_bind);
  s.root_parent.insert(s.root_parent.begin() + pos, mat4_identity());
}

std::string unique_name(const Skeleton& s, std::string name) {
  const std::string base = name;
  for (int k = 2; s.find(name) >= 0; ++k) name = base + "_" + std::to_string(k);
  return name;
}

// Joints with exactly one child at a distance (a segment to split).
std::vector<std::int32_t> splittable(const Skeleton& s) {
  const auto ch = s.children();
  std::vector<std::int32_t> out;
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    if (ch[std::size_t(j)].size() != 1) continue;
    const Vec3 d = sub(bind_head(s, ch[std::size_t(j)][0]), bind_head(s, j));
    if (dot(d, d) > 1e-12f) out.push_back(j);
  }
  return out;
}

bool has_weight(const Mesh& m, std::int32_t j) {
  return std::find(m.weights.joint.begin(), m.weights.joint.end(), j) != m.weights.joint.end();
}

}  // namespace

const char* augment_kind_name(AugmentKind k) {
  switch (k) {
    case AugmentKind::rigid: return "rigid";
    case AugmentKind::decimate: return "decimate";
    case AugmentKind::remesh: return "remesh";
    case AugmentKind::rename: return "rename";
    case AugmentKind::split: return "split";
    case AugmentKind::merge: return "merge";
    case AugmentKind::helpers: return "helpers";
    case AugmentKind::twist: return "twist";
    case AugmentKind::chains: return "chains";
    case AugmentKind::rotate: return "rotate";
    case AugmentKind::scale: return "scale";
    case AugmentKind::z_up: return "z-up";
  }
  return "?";
}

const std::vector<AugmentKind>& all_augment_kinds() {
  static const std::vector<AugmentKind> k{AugmentKind::rigid,   AugmentKind::decimate, AugmentKind::remesh,
                                          AugmentKind::rename,  AugmentKind::split,    AugmentKind::merge,
                                          AugmentKind::helpers, AugmentKind::twist,    AugmentKind::chains,
                                          AugmentKind::rotate,  AugmentKind::scale,    AugmentKind::z_up};
  return k;
}

std::vector<AugmentKind> parse_augment_kinds(const std::string& list, const std::string& what) {
  std::vector<AugmentKind> out;
  std::string known;
  for (AugmentKind k : all_augment_kinds()) {
    if (!known.empty()) known += ", ";
    known += augment_kind_name(k);
  }
  std::size_t start = 0;
  while (start <= list.size()) {
    const std::size_t end = std::min(list.find_first_of(",+", start), list.size());
    const std::string item = list.substr(start, end - start);
    start = end + 1;
    GATCORE_CHECK(!item.empty(), what, ": empty augmentation name in '", list, "' (known: ", known, ", all)");
    if (item == "all") {
      for (AugmentKind k : all_augment_kinds())
        if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
      continue;
    }
    const auto& all = all_augment_kinds();
    const auto it = std::find_if(all.begin(), all.end(), [&](AugmentKind k) { return item == augment_kind_name(k); });
    GATCORE_CHECK(it != all.end(), what, ": unknown augmentation '", item, "' (known: ", known, ", all)");
    GATCORE_CHECK(std::find(out.begin(), out.end(), *it) == out.end(), what, ": augmentation '", item,
                  "' is given twice");
    out.push_back(*it);
  }
  return out;
}

Character rigid_parts(const Character& c, std::uint32_t seed, const AugmentOptions& o) {
  Character r = c;
  const Components comp = connected_components(c.mesh);
  const std::int32_t J = c.skeleton.num_joints();
  std::vector<double> sum(std::size_t(comp.count) * std::size_t(J), 0.0), total(std::size_t(comp.count), 0.0);
  std::vector<std::int64_t> size(std::size_t(comp.count), 0);
  const SkinWeights& w = c.mesh.weights;
  for (std::int64_t v = 0; v < w.num_vertices(); ++v) {
    const auto p = std::size_t(comp.label[std::size_t(v)]);
    ++size[p];
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k) {
      sum[p * std::size_t(J) + std::size_t(w.joint[k])] += w.weight[k];
      total[p] += w.weight[k];
    }
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<std::int32_t> bone(std::size_t(comp.count), -1);
  for (std::int32_t p = 0; p < comp.count; ++p) {
    const double* row = &sum[std::size_t(p) * std::size_t(J)];
    const auto best = static_cast<std::int32_t>(std::max_element(row, row + J) - row);
    const bool dominated = total[std::size_t(p)] > 0 && row[best] >= o.rigid_share * total[std::size_t(p)];
    const bool small = double(size[std::size_t(p)]) < o.rigid_max_piece * double(w.num_vertices());
    const bool picked = u(rng) < o.rigid_pick;  // drawn for every piece, so one piece's choice never shifts another's
    if (dominated || (small && picked)) bone[std::size_t(p)] = best;
  }
  Influences in = unpack(w);
  for (std::int64_t v = 0; v < w.num_vertices(); ++v) {
    const std::int32_t b = bone[std::size_t(comp.label[std::size_t(v)])];
    if (b >= 0) in[std::size_t(v)] = {{b, 1.0f}};
  }
  r.mesh.weights = pack(in, o.max_influences);
  check(r, "rigid_parts");
  return r;
}

namespace {

// Keeps the vertices `tris` use (in order of first use is not needed: in
// their old order), with their weights.
Character compact(const Character& c, const std::vector<std::uint32_t>& tris, const AugmentOptions& o) {
  const std::int64_t n = c.mesh.num_vertices();
  std::vector<std::int32_t> remap(std::size_t(n), -1);
  for (std::uint32_t v : tris) remap[v] = 0;
  std::int32_t next = 0;
  for (auto& r : remap)
    if (r == 0) r = next++;
  Character out = c;
  out.mesh.positions.assign(std::size_t(next) * 3, 0.0f);
  Influences in = unpack(c.mesh.weights), kept(static_cast<std::size_t>(next));
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int32_t r = remap[std::size_t(v)];
    if (r < 0) continue;
    for (int a = 0; a < 3; ++a) out.mesh.positions[3 * std::size_t(r) + a] = c.mesh.positions[3 * std::size_t(v) + a];
    kept[std::size_t(r)] = in[std::size_t(v)];
  }
  out.mesh.triangles.clear();
  for (std::uint32_t v : tris) out.mesh.triangles.push_back(remap[v]);
  out.mesh.weights = pack(kept, o.max_influences);
  reset_file_maps(out);
  return out;
}

}  // namespace

Character decimate(const Character& c, float keep, const AugmentOptions& o) {
  GATCORE_CHECK(keep > 0.0f && keep <= 1.0f, "decimate: kept share ", keep, " is not in (0, 1]");
  const std::vector<std::uint32_t> idx(c.mesh.triangles.begin(), c.mesh.triangles.end());
  std::vector<std::uint32_t> dst(idx.size());
  const std::size_t target = std::size_t(double(idx.size() / 3) * keep) * 3;
  const std::size_t count =
      meshopt_simplify(dst.data(), idx.data(), idx.size(), c.mesh.positions.data(), std::size_t(c.mesh.num_vertices()),
                       3 * sizeof(float), target, 1.0f, meshopt_SimplifyLockBorder, nullptr);
  dst.resize(count);
  GATCORE_CHECK(!dst.empty(), "decimate: ", c.name, " has no triangles left");
  Character r = compact(c, dst, o);
  check(r, "decimate");
  return r;
}

Character remesh(const Character& c, float cells, const AugmentOptions& o, std::vector<std::int32_t>* source_triangle) {
  GATCORE_CHECK(cells >= 1.0f && std::isfinite(cells), "remesh: cells ", cells, " is below 1");
  const Mesh& m = c.mesh;
  const std::int64_t n = m.num_vertices();
  GATCORE_CHECK(n > 0 && m.num_triangles() > 0, "remesh: ", c.name, " has no triangles");
  Vec3 lo = vertex(m, 0), hi = lo;
  for (std::int64_t v = 0; v < n; ++v)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], m.positions[3 * std::size_t(v) + a]);
      hi[a] = std::max(hi[a], m.positions[3 * std::size_t(v) + a]);
    }
  const float side = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-12f});
  const float h = side / cells;
  const Components comp = connected_components(m);
  std::map<std::tuple<std::int32_t, std::int64_t, std::int64_t, std::int64_t>, std::int32_t> cluster_of;
  std::vector<std::int32_t> cluster(static_cast<std::size_t>(n));
  for (std::int64_t v = 0; v < n; ++v) {
    const Vec3 p = vertex(m, v);
    const auto key = std::make_tuple(comp.label[std::size_t(v)], std::int64_t(std::floor((p[0] - lo[0]) / h)),
                                     std::int64_t(std::floor((p[1] - lo[1]) / h)),
                                     std::int64_t(std::floor((p[2] - lo[2]) / h)));
    const auto it = cluster_of.emplace(key, static_cast<std::int32_t>(cluster_of.size())).first;
    cluster[std::size_t(v)] = it->second;
  }
  const std::size_t nc = cluster_of.size();
  // New triangles: those whose three clusters differ, once each.
  std::set<std::array<std::int32_t, 3>> seen;
  std::vector<std::int32_t> tris;
  std::vector<std::vector<std::int32_t>> around(nc);  // source triangles touching each cluster
  for (std::int64_t t = 0; t < m.num_triangles(); ++t) {
    std::array<std::int32_t, 3> k{};
    for (int a = 0; a < 3; ++a) {
      k[a] = cluster[std::size_t(m.triangles[3 * std::size_t(t) + a])];
      around[std::size_t(k[a])].push_back(static_cast<std::int32_t>(t));
    }
    if (k[0] == k[1] || k[1] == k[2] || k[0] == k[2]) continue;
    std::array<std::int32_t, 3> s = k;
    std::sort(s.begin(), s.end());
    if (!seen.insert(s).second) continue;
    tris.insert(tris.end(), k.begin(), k.end());
  }
  GATCORE_CHECK(!tris.empty(), "remesh: ", c.name, " has no triangles left at ", cells, " cells");
  // Vertices that are left in a triangle; each at its members' centroid.
  std::vector<double> centroid(nc * 3, 0.0);
  std::vector<std::int64_t> members(nc, 0);
  for (std::int64_t v = 0; v < n; ++v) {
    const auto k = std::size_t(cluster[std::size_t(v)]);
    for (int a = 0; a < 3; ++a) centroid[3 * k + a] += m.positions[3 * std::size_t(v) + a];
    ++members[k];
  }
  std::vector<std::int32_t> remap(nc, -1);
  std::int32_t next = 0;
  for (std::int32_t k : tris)
    if (remap[std::size_t(k)] < 0) remap[std::size_t(k)] = next++;
  Character r = c;
  r.mesh.positions.assign(std::size_t(next) * 3, 0.0f);
  r.mesh.triangles.clear();
  for (std::int32_t k : tris) r.mesh.triangles.push_back(remap[std::size_t(k)]);
  Influences in(static_cast<std::size_t>(next));
  if (source_triangle) source_triangle->assign(std::size_t(next), -1);
  for (std::size_t k = 0; k < nc; ++k) {
    const std::int32_t nv = remap[k];
    if (nv < 0) continue;
    Vec3 p;
    for (int a = 0; a < 3; ++a) {
      p[a] = static_cast<float>(centroid[3 * k + a] / double(members[k]));
      r.mesh.positions[3 * std::size_t(nv) + a] = p[a];
    }
    // The nearest point of the source triangles around the cluster.
    float best = INFINITY;
    std::int32_t best_t = -1;
    std::array<float, 3> best_bary{};
    for (std::int32_t t : around[k]) {
      const Vec3 a = vertex(m, m.triangles[3 * std::size_t(t)]), b = vertex(m, m.triangles[3 * std::size_t(t) + 1]),
                 cc = vertex(m, m.triangles[3 * std::size_t(t) + 2]);
      // Ericson, Real-Time Collision Detection 5.1.5: closest point on a triangle.
      const Vec3 ab = sub(b, a), ac = sub(cc, a), ap = sub(p, a);
      const float d1 = dot(ab, ap), d2 = dot(ac, ap);
      std::array<float, 3> bary;
      const Vec3 bp = sub(p, b), cp = sub(p, cc);
      const float d3 = dot(ab, bp), d4 = dot(ac, bp), d5 = dot(ab, cp), d6 = dot(ac, cp);
      const float vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
      if (d1 <= 0 && d2 <= 0) bary = {1, 0, 0};
      else if (d3 >= 0 && d4 <= d3) bary = {0, 1, 0};
      else if (vc <= 0 && d1 >= 0 && d3 <= 0) { const float x = d1 / (d1 - d3); bary = {1 - x, x, 0}; }
      else if (d6 >= 0 && d5 <= d6) bary = {0, 0, 1};
      else if (vb <= 0 && d2 >= 0 && d6 <= 0) { const float x = d2 / (d2 - d6); bary = {1 - x, 0, x}; }
      else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const float x = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        bary = {0, 1 - x, x};
      } else {
        const float den = va + vb + vc;
        if (!(std::abs(den) > 0)) bary = {1, 0, 0};  // a degenerate triangle: its first corner
        else bary = {va / den, vb / den, vc / den};
      }
      Vec3 q;
      for (int i = 0; i < 3; ++i) q[i] = bary[0] * a[i] + bary[1] * b[i] + bary[2] * cc[i];
      const Vec3 d = sub(p, q);
      if (dot(d, d) < best) {
        best = dot(d, d);
        best_t = t;
        best_bary = bary;
      }
    }
    const SkinWeights& w = m.weights;
    for (int a = 0; a < 3; ++a) {
      const std::int32_t v = m.triangles[3 * std::size_t(best_t) + a];
      for (std::int64_t q = w.ptr[v]; q < w.ptr[v + 1]; ++q)
        in[std::size_t(nv)].push_back({w.joint[q], best_bary[a] * w.weight[q]});
    }
    if (source_triangle) (*source_triangle)[std::size_t(nv)] = best_t;
  }
  r.mesh.weights = pack(in, o.max_influences);
  reset_file_maps(r);
  check(r, "remesh");
  return r;
}

Character split_bone(const Character& c, std::int32_t bone, float at, const std::string& name, bool take_children,
                     const AugmentOptions& o) {
  const Skeleton& s = c.skeleton;
  GATCORE_CHECK(bone >= 0 && bone < s.num_joints(), "split_bone: joint ", bone, " of ", s.num_joints());
  GATCORE_CHECK(at > 0.0f && at < 1.0f, "split_bone: position ", at, " is not in (0, 1)");
  const auto ch = s.children()[std::size_t(bone)];
  GATCORE_CHECK(ch.size() == 1, "split_bone: ", s.names[std::size_t(bone)], " has ", ch.size(),
                " children (a segment needs exactly one)");
  const Vec3 head = bind_head(s, bone), tail = bind_head(s, ch[0]), d = sub(tail, head);
  const float len2 = dot(d, d);
  GATCORE_CHECK(len2 > 1e-12f, "split_bone: ", s.names[std::size_t(bone)], " has no length");
  // The new joint: the bone's bind frame moved to head + at * d, so its
  // offset in the bone's frame is a pure translation.
  const Mat4 B = inverse(s.inverse_bind[std::size_t(bone)]);
  Mat4 Bn = B;
  for (int a = 0; a < 3; ++a) Bn[12 + a] = head[a] + at * d[a];
  Transform offset;
  offset.translation = mat4_translation(mul(s.inverse_bind[std::size_t(bone)], Bn));
  Character r = c;
  const std::int32_t pos = bone + 1;
  insert_joint(r, pos, unique_name(s, name), bone, offset, inverse(Bn));
  if (take_children) {
    Skeleton& rs = r.skeleton;
    for (std::int32_t j = pos + 1; j < rs.num_joints(); ++j)
      if (rs.parents[std::size_t(j)] == bone) {
        rs.parents[std::size_t(j)] = pos;
        for (int a = 0; a < 3; ++a) rs.rest_local[std::size_t(j)].translation[a] -= offset.translation[a];
      }
  }
  // Weights on the bone: the share beyond `at` (a ramp o.ramp bone lengths
  // wide) goes to the new joint.
  Influences in = unpack(r.mesh.weights);
  for (std::int64_t v = 0; v < r.mesh.num_vertices(); ++v) {
    auto& row = in[std::size_t(v)];
    const float t = dot(sub(vertex(r.mesh, v), head), d) / len2;
    const float f = std::clamp((t - at) / std::max(o.ramp, 1e-6f) + 0.5f, 0.0f, 1.0f);
    const std::size_t old = row.size();
    for (std::size_t k = 0; k < old; ++k)
      if (row[k].first == bone && f > 0.0f) {
        row.push_back({pos, row[k].second * f});
        row[k].second *= 1.0f - f;
      }
  }
  r.mesh.weights = pack(in, o.max_influences);
  reset_file_maps(r);
  check(r, "split_bone");
  return r;
}

Character merge_bone(const Character& c, std::int32_t child, const AugmentOptions& o) {
  const Skeleton& s = c.skeleton;
  GATCORE_CHECK(child >= 0 && child < s.num_joints(), "merge_bone: joint ", child, " of ", s.num_joints());
  const std::int32_t parent = s.parents[std::size_t(child)];
  GATCORE_CHECK(parent >= 0, "merge_bone: ", s.names[std::size_t(child)], " is a root");
  Character r = c;
  Skeleton& rs = r.skeleton;
  const Mat4 L = to_matrix(s.rest_local[std::size_t(child)]);
  for (std::int32_t j = 0; j < s.num_joints(); ++j)
    if (s.parents[std::size_t(j)] == child) {
      rs.parents[std::size_t(j)] = parent;
      rs.rest_local[std::size_t(j)] = to_transform(mul(L, to_matrix(s.rest_local[std::size_t(j)])));
    }
  for (auto& p : rs.parents)
    if (p > child) --p;
  auto erase = [&](auto& v) { v.erase(v.begin() + child); };
  erase(rs.names);
  erase(rs.parents);
  erase(rs.rest_local);
  erase(rs.inverse_bind);
  erase(rs.root_parent);
  Influences in = unpack(c.mesh.weights);
  for (auto& row : in)
    for (auto& [j, x] : row) {
      if (j == child) j = parent;
      else if (j > child) --j;
    }
  r.mesh.weights = pack(in, o.max_influences);
  reset_file_maps(r);
  check(r, "merge_bone");
  return r;
}

const std::vector<std::string>& rename_conventions() {
  static const std::vector<std::string> k{"mixamo", "unreal"};
  return k;
}

namespace {

// A body part's name in a convention ("" where the convention has none).
std::string convention_name(const std::string& convention, const std::string& part) {
  std::string base = part, side;
  if (part.size() > 2 && part[part.size() - 2] == '.') {
    side = part.substr(part.size() - 1);
    base = part.substr(0, part.size() - 2);
  }
  std::size_t digits = base.size();
  while (digits > 0 && std::isdigit(static_cast<unsigned char>(base[digits - 1]))) --digits;
  const int n = digits < base.size() ? std::atoi(base.c_str() + digits) : 0;
  const std::string stem = base.substr(0, digits);
  const bool finger = stem == "thumb" || stem == "index" || stem == "middle" || stem == "ring" || stem == "pinky";
  if (convention == "mixamo") {
    const std::string s = side.empty() ? "" : side == "l" ? "Left" : "Right";
    static const std::map<std::string, std::string> m{{"pelvis", "Hips"},    {"head", "Head"},         {"clavicle", "Shoulder"},
                                                       {"upperarm", "Arm"},  {"forearm", "ForeArm"},   {"hand", "Hand"},
                                                       {"thigh", "UpLeg"},   {"shin", "Leg"},          {"foot", "Foot"},
                                                       {"toe", "ToeBase"}};
    if (stem == "spine" && n >= 1 && n <= 10) return "mixamorig:Spine" + (n == 1 ? std::string() : std::to_string(n - 1));
    if (stem == "neck" && n >= 1 && n <= 4) return "mixamorig:Neck" + (n == 1 ? std::string() : std::to_string(n - 1));
    if (finger && n >= 1 && n <= 4) {
      std::string f = stem;
      f[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(f[0])));
      return "mixamorig:" + s + "Hand" + f + std::to_string(n);
    }
    const auto it = m.find(stem);
    return it == m.end() || n != 0 ? "" : "mixamorig:" + s + it->second;
  }
  if (convention == "unreal") {
    const std::string s = side.empty() ? "" : "_" + side;
    static const std::map<std::string, std::string> m{{"pelvis", "pelvis"},     {"head", "head"},   {"clavicle", "clavicle"},
                                                       {"upperarm", "upperarm"}, {"forearm", "lowerarm"}, {"hand", "hand"},
                                                       {"thigh", "thigh"},       {"shin", "calf"},   {"foot", "foot"},
                                                       {"toe", "ball"}};
    if (stem == "spine" && n >= 1 && n <= 5) return "spine_0" + std::to_string(n);
    if (stem == "neck" && n >= 1 && n <= 2) return "neck_0" + std::to_string(n);
    if (finger && n >= 1 && n <= 3) return stem + "_0" + std::to_string(n) + s;
    const auto it = m.find(stem);
    return it == m.end() || n != 0 ? "" : it->second + s;
  }
  throw InvalidArgument("rename_bones: unknown convention '" + convention + "' (mixamo, unreal)");
}

}  // namespace

Character rename_bones(const Character& c, const std::string& convention) {
  const RigMapping map = map_rig(c.skeleton);
  Character r = c;
  Skeleton& s = r.skeleton;
  std::vector<std::string> names(s.names.size());
  std::set<std::string> used;
  for (std::size_t j = 0; j < names.size(); ++j) {
    if (map.role[j] != JointRole::body || map.body[j].empty()) continue;
    const std::string n = convention_name(convention, map.body[j]);
    if (!n.empty() && used.insert(n).second) names[j] = n;
  }
  for (std::size_t j = 0; j < names.size(); ++j) {
    if (!names[j].empty()) continue;
    std::string n = c.skeleton.names[j];
    for (int k = 2; used.count(n); ++k) n = c.skeleton.names[j] + "_" + std::to_string(k);
    used.insert(n);
    names[j] = n;
  }
  s.names = names;
  check(r, "rename_bones");
  return r;
}

Character add_helper_bones(const Character& c, std::uint32_t seed) {
  Character r = c;
  Skeleton& s = r.skeleton;
  const RigMapping map = map_rig(c.skeleton);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  // Length scale: the bind skeleton's extent.
  float extent = 0;
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    const Vec3 d = sub(bind_head(s, j), bind_head(s, 0));
    extent = std::max(extent, std::sqrt(dot(d, d)));
  }
  if (!(extent > 0)) extent = 1;
  auto add = [&](const std::string& name, std::int32_t parent) {
    Transform t;
    for (int a = 0; a < 3; ++a) t.translation[a] = 0.05f * extent * u(rng);
    // The parent's bind frame (scaled, maybe) times the local offset, so
    // the helper's bind and rest transforms agree with its parent's.
    const Mat4 Bn = mul(inverse(s.inverse_bind[std::size_t(parent)]), to_matrix(t));
    insert_joint(r, s.num_joints(), unique_name(s, name), parent, t, inverse(Bn));
  };
  add("ik_foot_root", 0);
  add("ik_hand_root", 0);
  add("ik_hand_gun", s.num_joints() - 1);
  for (const char* side : {"l", "r"}) {
    const std::int32_t foot = map.find(std::string("foot.") + side), hand = map.find(std::string("hand.") + side);
    add(std::string("ik_foot_") + side, foot >= 0 ? foot : 0);
    add(std::string("ik_hand_") + side, hand >= 0 ? hand : 0);
    const std::int32_t knee = map.find(std::string("shin.") + side);
    add(std::string("pole_knee_") + side, knee >= 0 ? knee : 0);
  }
  const std::int32_t socket = static_cast<std::int32_t>(std::uniform_int_distribution<int>(0, c.skeleton.num_joints() - 1)(rng));
  add("prop_socket", socket);
  reset_file_maps(r);
  check(r, "add_helper_bones");
  return r;
}

Character transform_character(const Character& c, const Mat4& m) {
  Character r = c;
  const Mat4 mi = inverse(m);
  for (std::int64_t v = 0; v < c.mesh.num_vertices(); ++v) {
    const Vec3 p = transform_point(m, vertex(c.mesh, v));
    for (int a = 0; a < 3; ++a) r.mesh.positions[3 * std::size_t(v) + a] = p[a];
  }
  Skeleton& s = r.skeleton;
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    s.inverse_bind[std::size_t(j)] = mul(s.inverse_bind[std::size_t(j)], mi);
    if (s.parents[std::size_t(j)] < 0) s.root_parent[std::size_t(j)] = mul(m, s.root_parent[std::size_t(j)]);
  }
  for (auto& p : r.primitives) p.to_bind = mul(m, p.to_bind);
  check(r, "transform_character");
  return r;
}

Character augment_character(const Character& c, const std::vector<AugmentKind>& kinds, std::uint32_t seed,
                            const AugmentOptions& o) {
  auto has = [&](AugmentKind k) { return std::find(kinds.begin(), kinds.end(), k) != kinds.end(); };
  // One stream per kind, so adding a kind to a list leaves the others' draws alone.
  auto rng_for = [&](AugmentKind k) { return std::mt19937(seed * 2654435761u + 97u * (1u + unsigned(k))); };
  auto uniform = [](std::mt19937& g, float lo, float hi) { return std::uniform_real_distribution<float>(lo, hi)(g); };
  Character r = c;
  if (has(AugmentKind::rigid)) {
    auto g = rng_for(AugmentKind::rigid);
    r = rigid_parts(r, g(), o);
  }
  if (has(AugmentKind::remesh)) {
    auto g = rng_for(AugmentKind::remesh);
    r = remesh(r, uniform(g, o.remesh_cells_min, o.remesh_cells_max), o);
  } else if (has(AugmentKind::decimate)) {
    auto g = rng_for(AugmentKind::decimate);
    r = decimate(r, uniform(g, o.decimate_min, o.decimate_max), o);
  }
  auto pick = [](std::mt19937& g, const std::vector<std::int32_t>& from) {
    return from[std::size_t(std::uniform_int_distribution<std::size_t>(0, from.size() - 1)(g))];
  };
  if (has(AugmentKind::twist)) {
    for (const char* part : {"upperarm", "forearm", "thigh"})
      for (const char* side : {".l", ".r"}) {
        // Indices shift with each inserted twist bone: map the current skeleton.
        const std::int32_t now = map_rig(r.skeleton).find(std::string(part) + side);
        const auto sp = splittable(r.skeleton);
        if (now < 0 || std::find(sp.begin(), sp.end(), now) == sp.end()) continue;
        r = split_bone(r, now, 0.5f, r.skeleton.names[std::size_t(now)] + "_twist_01", false, o);
      }
  }
  if (has(AugmentKind::merge)) {
    auto g = rng_for(AugmentKind::merge);
    std::vector<std::int32_t> cand;
    for (std::int32_t j = 0; j < r.skeleton.num_joints(); ++j)
      if (r.skeleton.parents[std::size_t(j)] >= 0 && has_weight(r.mesh, j)) cand.push_back(j);
    if (!cand.empty()) r = merge_bone(r, pick(g, cand), o);
  }
  if (has(AugmentKind::split)) {
    auto g = rng_for(AugmentKind::split);
    std::vector<std::int32_t> cand;
    for (std::int32_t j : splittable(r.skeleton))
      if (has_weight(r.mesh, j)) cand.push_back(j);
    if (!cand.empty()) {
      const std::int32_t j = pick(g, cand);
      r = split_bone(r, j, uniform(g, 0.3f, 0.7f), r.skeleton.names[std::size_t(j)] + "_part2", true, o);
    }
  }
  if (has(AugmentKind::chains)) {
    auto g = rng_for(AugmentKind::chains);
    const RigMapping map = map_rig(r.skeleton);
    std::vector<std::int32_t> chain;
    for (std::int32_t j = 0; j < r.skeleton.num_joints(); ++j) {
      const std::string& b = map.body[std::size_t(j)];
      if (map.role[std::size_t(j)] != JointRole::body) continue;
      for (const char* p : {"spine", "neck", "thumb", "index", "middle", "ring", "pinky"})
        if (b.rfind(p, 0) == 0) chain.push_back(j);
    }
    if (!chain.empty()) {
      const std::int32_t j = pick(g, chain);
      const auto sp = splittable(r.skeleton);
      const std::int32_t parent = r.skeleton.parents[std::size_t(j)];
      const bool parent_in_chain = parent >= 0 && std::find(chain.begin(), chain.end(), parent) != chain.end();
      const bool can_split = std::find(sp.begin(), sp.end(), j) != sp.end();
      if (can_split && (!parent_in_chain || g() % 2 == 0))
        r = split_bone(r, j, 0.5f, r.skeleton.names[std::size_t(j)] + "_b", true, o);
      else if (parent_in_chain)
        r = merge_bone(r, j, o);
    }
  }
  if (has(AugmentKind::helpers)) {
    auto g = rng_for(AugmentKind::helpers);
    r = add_helper_bones(r, g());
  }
  if (has(AugmentKind::rename)) {
    auto g = rng_for(AugmentKind::rename);
    const auto& conv = rename_conventions();
    r = rename_bones(r, conv[g() % conv.size()]);
  }
  Mat4 place = mat4_identity();
  if (has(AugmentKind::rotate)) {
    auto g = rng_for(AugmentKind::rotate);
    const Quat yaw = quat_from_axis_angle({0, 1, 0}, uniform(g, -3.14159265f, 3.14159265f));
    const Quat tilt = quat_from_axis_angle({1, 0, 0}, uniform(g, -0.2f, 0.2f));
    Transform t;
    t.rotation = quat_normalize(quat_mul(tilt, yaw));
    place = mul(to_matrix(t), place);
  }
  if (has(AugmentKind::scale)) {
    auto g = rng_for(AugmentKind::scale);
    Transform t;
    const float s = std::pow(10.0f, uniform(g, -2.0f, 2.0f));
    t.scale = {s, s, s};
    place = mul(to_matrix(t), place);
  }
  if (has(AugmentKind::z_up)) {
    Transform t;  // +Y up -> +Z up: +90 degrees about X
    t.rotation = quat_from_axis_angle({1, 0, 0}, 1.5707963f);
    place = mul(to_matrix(t), place);
  }
  if (has(AugmentKind::rotate) || has(AugmentKind::scale) || has(AugmentKind::z_up)) r = transform_character(r, place);
  std::string stem = c.name;
  const std::size_t dot_at = stem.find_last_of('.'), slash = stem.find_last_of('/');
  if (dot_at != std::string::npos && (slash == std::string::npos || dot_at > slash)) stem = stem.substr(0, dot_at);
  r.name = stem + "~aug" + std::to_string(seed);
  return r;
}

bool is_augment_entry(const std::string& entry) { return entry.rfind("augment:", 0) == 0; }

std::string augment_entry(const AugmentEntry& e) {
  GATCORE_CHECK(!e.kinds.empty(), "augment_entry: no augmentations for ", e.source);
  GATCORE_CHECK(!e.source.empty(), "augment_entry: no source");
  std::string k;
  for (AugmentKind x : e.kinds) {
    if (!k.empty()) k += '+';
    k += augment_kind_name(x);
  }
  return "augment:" + k + ":" + std::to_string(e.seed) + ":" + e.source;
}

AugmentEntry parse_augment_entry(const std::string& entry) {
  const std::string what = "dataset character '" + entry + "'";
  GATCORE_CHECK(is_augment_entry(entry), what, ": not an augment:KINDS:SEED:SOURCE entry");
  const std::size_t a = 8, b = entry.find(':', a);
  GATCORE_CHECK(b != std::string::npos, what, ": expected augment:KINDS:SEED:SOURCE");
  const std::size_t c = entry.find(':', b + 1);
  GATCORE_CHECK(c != std::string::npos && c + 1 < entry.size(), what, ": expected augment:KINDS:SEED:SOURCE");
  AugmentEntry e;
  e.kinds = parse_augment_kinds(entry.substr(a, b - a), what);
  const std::string seed = entry.substr(b + 1, c - b - 1);
  char* end = nullptr;
  const unsigned long long s = std::strtoull(seed.c_str(), &end, 10);
  GATCORE_CHECK(!seed.empty() && end && *end == '\0' && seed[0] != '-' && s <= 4294967295ull, what, ": seed '", seed,
                "' is not a number in [0, 4294967295]");
  e.seed = static_cast<std::uint32_t>(s);
  e.source = entry.substr(c + 1);
  GATCORE_CHECK(!is_augment_entry(e.source), what, ": the source is itself a variant");
  return e;
}

}  // namespace gatcore::character
