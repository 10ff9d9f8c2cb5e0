#include "gatcore/character/deform/bone_heat.hpp"

#include "gatcore/character/rig/blend_weights.hpp"
#include "gatcore/character/rig/bone_axis.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>
#include <unordered_map>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/character/rig/vec3.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

using V3 = Vec3d;

// Closest point to p on segment [a, b]; *past_tail: how far p projects
// beyond b along the bone (0 if it does not).
V3 closest_on_segment(const V3& p, const V3& a, const V3& b, double* past_tail) {
  const V3 ab = sub(b, a);
  const double l2 = dot(ab, ab);
  const double t0 = l2 > 0 ? dot(sub(p, a), ab) / l2 : 0.0;
  *past_tail = l2 > 0 && t0 > 1.0 ? (t0 - 1.0) * std::sqrt(l2) : 0.0;
  const double t = std::clamp(t0, 0.0, 1.0);
  return {a[0] + t * ab[0], a[1] + t * ab[1], a[2] + t * ab[2]};
}

// A bounding-volume hierarchy over triangles for the visibility test
// (does the open segment p -> q cross a triangle not incident to vertex v?).
struct Bvh {
  struct Node {
    V3 lo, hi;
    std::int32_t left = -1, right = -1, first = 0, count = 0;
  };
  std::vector<Node> nodes;
  std::vector<std::int32_t> order;  // triangle ids
  const std::vector<V3>* pos = nullptr;
  const std::vector<std::int32_t>* tris = nullptr;

  void build(const std::vector<V3>& p, const std::vector<std::int32_t>& t) {
    pos = &p;
    tris = &t;
    const std::int32_t nt = static_cast<std::int32_t>(t.size() / 3);
    order.resize(static_cast<std::size_t>(nt));
    std::iota(order.begin(), order.end(), 0);
    std::vector<V3> centre(static_cast<std::size_t>(nt));
    for (std::int32_t i = 0; i < nt; ++i)
      for (int c = 0; c < 3; ++c)
        centre[i][c] = (p[t[3 * i]][c] + p[t[3 * i + 1]][c] + p[t[3 * i + 2]][c]) / 3.0;
    nodes.clear();
    if (nt > 0) split(0, nt, centre);
  }

  std::int32_t split(std::int32_t first, std::int32_t count, const std::vector<V3>& centre) {
    Node n;
    n.lo = {1e300, 1e300, 1e300};
    n.hi = {-1e300, -1e300, -1e300};
    for (std::int32_t i = first; i < first + count; ++i)
      for (int k = 0; k < 3; ++k) {
        const V3& x = (*pos)[(*tris)[3 * order[i] + k]];
        for (int c = 0; c < 3; ++c) n.lo[c] = std::min(n.lo[c], x[c]), n.hi[c] = std::max(n.hi[c], x[c]);
      }
    const std::int32_t id = static_cast<std::int32_t>(nodes.size());
    nodes.push_back(n);
    if (count <= 4) {
      nodes[id].first = first;
      nodes[id].count = count;
      return id;
    }
    int axis = 0;
    for (int c = 1; c < 3; ++c)
      if (n.hi[c] - n.lo[c] > n.hi[axis] - n.lo[axis]) axis = c;
    const std::int32_t mid = first + count / 2;
    std::nth_element(order.begin() + first, order.begin() + mid, order.begin() + first + count,
                     [&](std::int32_t a, std::int32_t b) { return centre[a][axis] < centre[b][axis]; });
    const std::int32_t l = split(first, mid - first, centre);
    const std::int32_t r = split(mid, first + count - mid, centre);
    nodes[id].left = l;
    nodes[id].right = r;
    return id;
  }

  static bool segment_hits_box(const V3& p, const V3& d, const V3& lo, const V3& hi) {
    double t0 = 0, t1 = 1;
    for (int c = 0; c < 3; ++c) {
      if (std::abs(d[c]) < 1e-300) {
        if (p[c] < lo[c] || p[c] > hi[c]) return false;
        continue;
      }
      double a = (lo[c] - p[c]) / d[c], b = (hi[c] - p[c]) / d[c];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
      if (t0 > t1) return false;
    }
    return true;
  }

  // Moller-Trumbore on the segment p + t d, t in (eps, 1 - eps).
  bool segment_hits_triangle(const V3& p, const V3& d, std::int32_t tri) const {
    const V3& a = (*pos)[(*tris)[3 * tri]];
    const V3 e1 = sub((*pos)[(*tris)[3 * tri + 1]], a), e2 = sub((*pos)[(*tris)[3 * tri + 2]], a);
    const V3 h = cross(d, e2);
    const double det = dot(e1, h);
    if (std::abs(det) < 1e-30) return false;
    const double f = 1.0 / det;
    const V3 s = sub(p, a);
    const double u = f * dot(s, h);
    if (u < 0 || u > 1) return false;
    const V3 q = cross(s, e1);
    const double v = f * dot(d, q);
    if (v < 0 || u + v > 1) return false;
    const double t = f * dot(e2, q);
    return t > 1e-6 && t < 1 - 1e-6;
  }

  // Does the ray from p along d (within length |d|) hit any triangle?
  bool hits(const V3& p, const V3& d) const { return blocked(p, {p[0] + d[0], p[1] + d[1], p[2] + d[2]}, -1); }

  bool blocked(const V3& p, const V3& q, std::int32_t vertex) const {
    if (nodes.empty()) return false;
    const V3 d = sub(q, p);
    std::int32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes[stack[--top]];
      if (!segment_hits_box(p, d, n.lo, n.hi)) continue;
      if (n.left < 0) {
        for (std::int32_t i = n.first; i < n.first + n.count; ++i) {
          const std::int32_t t = order[i];
          const std::int32_t* tv = tris->data() + 3 * t;
          if (tv[0] == vertex || tv[1] == vertex || tv[2] == vertex) continue;
          if (segment_hits_triangle(p, d, t)) return true;
        }
      } else if (top + 2 <= 128) {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
    return false;
  }
};

// The settings bone_segments reads; `what` names the caller's subject.
void check_segment_params(const BoneHeatParams& params, const std::string& what) {
  GATCORE_CHECK(std::isfinite(params.branch_cos) && std::isfinite(params.continue_cos) &&
                    std::isfinite(params.leaf_extension) && params.leaf_extension >= 0,
                what, ": bone segments need finite branch_cos, continue_cos and leaf_extension >= 0, got ",
                params.branch_cos, ", ", params.continue_cos, ", ", params.leaf_extension);
}

}  // namespace

std::vector<std::vector<BoneSegment>> bone_segments(const Skeleton& s, const BoneHeatParams& params) {
  const std::int32_t nj = s.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(s.inverse_bind.size()) == nj, "bone_segments: ", s.inverse_bind.size(),
                " inverse bind matrices for ", nj, " joints");
  check_segment_params(params, "bone_segments");
  std::vector<Mat4> bind(static_cast<std::size_t>(nj));
  std::vector<Vec3> head(static_cast<std::size_t>(nj));
  for (std::int32_t j = 0; j < nj; ++j) {
    bind[j] = inverse(s.inverse_bind[j]);
    head[j] = mat4_translation(bind[j]);
  }
  const auto children = s.children();
  auto dir = [&](std::int32_t a, std::int32_t b) {
    V3 d = sub(to_double(head[b]), to_double(head[a]));
    const double l = length(d);
    if (l > 0)
      for (double& x : d) x /= l;
    return d;
  };
  // A leaf's bone follows the rig's own bone-axis convention
  // (rig/bone_axis.hpp): a foot without toe joints points forward, not down
  // its shin.
  const BoneAxis conv = bone_axis_convention(s);
  // Every joint gets at least one segment (its best branch, or its leaf bone).
  std::vector<std::vector<BoneSegment>> seg(static_cast<std::size_t>(nj));
  std::vector<std::uint8_t> chain(static_cast<std::size_t>(nj));  // a leaf's ancestors
  for (std::int32_t j = 0; j < nj; ++j) {
    const std::int32_t p = s.parents[j];
    // Branches (a child turning away from the parent's direction, like the
    // arms off a collar, or any child beside one that carries the chain
    // straight on, like the shoulders off the chest) are their own bones,
    // not this joint's.
    std::vector<double> cs;
    for (std::int32_t c : children[j]) cs.push_back(p >= 0 ? dot(dir(p, j), dir(j, c)) : 1.0);
    const auto best = std::max_element(cs.begin(), cs.end());
    if (best != cs.end()) {
      const double keep_cos = *best >= params.continue_cos ? params.continue_cos : params.branch_cos;
      for (std::size_t i = 0; i < cs.size(); ++i)
        if (cs[i] >= keep_cos) seg[j].push_back({head[j], head[children[j][i]]});
      if (seg[j].empty()) seg[j].push_back({head[j], head[children[j][std::size_t(best - cs.begin())]]});
    }
    if (!children[j].empty()) continue;
    Vec3 tail = head[j];
    if (p >= 0) {
      const double plen = length(sub(to_double(head[j]), to_double(head[p])));
      const Vec3 b = bone_direction(s, j, conv);
      const V3 d{b[0], b[1], b[2]};
      // glTF keeps no bone tails. Where a joint outside this chain sits on
      // the leaf's own axis within 1.5 parent lengths, it marks the tail: an
      // IK foot target hanging off the root where the shin ends.
      // Stylised legs have shins up to 3 thigh lengths long (a 1.6x shin
      // ending at an IK foot off the root, left at half a thigh, hands the
      // lower shin to the foot), so a limb's last bone (a leaf that is no
      // root's child) reaches up to 3 parent lengths, to a joint where IK
      // targets hang: a root or a root's child. A joint deeper in another
      // chain (a fin's axis crossing the spine) is no tail, and a root's own
      // leaf (an IK foot pointing at a pole target) keeps 1.5.
      std::int32_t at = -1;
      double at_len = 3.0 * plen;
      const bool limb_end = s.parents[p] >= 0;
      std::fill(chain.begin(), chain.end(), 0);
      for (std::int32_t a = j; a >= 0; a = s.parents[a]) chain[a] = 1;
      for (std::int32_t k = 0; k < nj; ++k) {
        if (chain[k]) continue;
        const V3 v = sub(to_double(head[k]), to_double(head[j]));
        const double l = length(v);
        if (!(l > 0 && l <= at_len && dot(v, d) >= 0.9 * l)) continue;
        const bool ik_target = s.parents[k] < 0 || s.parents[s.parents[k]] < 0;
        if (l <= 1.5 * plen || (limb_end && ik_target)) at = k, at_len = l;
      }
      if (at >= 0) {
        tail = head[at];
      } else {
        const double len = params.leaf_extension * plen;
        for (int c = 0; c < 3; ++c) tail[c] += static_cast<float>(len * d[c]);
      }
    }
    seg[j].push_back({head[j], tail});
  }
  return seg;
}

SkinWeights bone_heat_weights(const Character& ch, const BoneHeatParams& params) {
  const Mesh& mesh = ch.mesh;
  const Skeleton& sk = ch.skeleton;
  sk.validate(ch.name.c_str());
  const std::int32_t nj = sk.num_joints();
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(n > 0, ch.name, ": bone heat needs a mesh with vertices");
  GATCORE_CHECK(std::isfinite(params.heat) && params.heat > 0, ch.name, ": bone heat constant must be > 0, got ",
                params.heat);
  GATCORE_CHECK(std::isfinite(params.cut_below) && std::isfinite(params.ramp_until) && params.cut_below >= 0 &&
                    params.ramp_until >= params.cut_below,
                ch.name, ": bone heat weight limit needs 0 <= cut_below <= ramp_until, got cut_below ",
                params.cut_below, ", ramp_until ", params.ramp_until);
  check_segment_params(params, ch.name);
  GATCORE_CHECK(params.deforming.empty() || static_cast<std::int32_t>(params.deforming.size()) == nj, ch.name,
                ": bone heat deforming mask has ", params.deforming.size(), " entries for ", nj, " joints");
  GATCORE_CHECK(params.joint_override.empty() || static_cast<std::int32_t>(params.joint_override.size()) == nj,
                ch.name, ": bone heat joint overrides have ", params.joint_override.size(), " entries for ", nj,
                " joints");
  for (float x : mesh.positions) GATCORE_CHECK(std::isfinite(x), ch.name, ": a vertex position is not finite");
  for (std::int32_t t : mesh.triangles)
    GATCORE_CHECK(t >= 0 && t < n, ch.name, ": triangle vertex ", t, " out of range (", n, " vertices)");

  // Welded copy (exact-position weld with a tiny tolerance) for the diffusion.
  std::vector<V3> pos0(static_cast<std::size_t>(n));
  V3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::int64_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) {
      pos0[v][c] = mesh.positions[3 * v + c];
      lo[c] = std::min(lo[c], pos0[v][c]);
      hi[c] = std::max(hi[c], pos0[v][c]);
    }
  const double diag = std::max(length(sub(hi, lo)), 1e-12);
  const double tol = 1e-6 * diag;
  std::vector<std::int32_t> weld(static_cast<std::size_t>(n));
  std::vector<V3> pos;
  {
    std::unordered_map<std::uint64_t, std::vector<std::int32_t>> grid;
    auto cell = [&](const V3& p, int c) { return static_cast<std::int64_t>(std::floor((p[c] - lo[c]) / tol)); };
    auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
      return static_cast<std::uint64_t>(x) * 73856093ULL ^ static_cast<std::uint64_t>(y) * 19349663ULL ^
             static_cast<std::uint64_t>(z) * 83492791ULL;
    };
    for (std::int64_t v = 0; v < n; ++v) {
      const std::int64_t cx = cell(pos0[v], 0), cy = cell(pos0[v], 1), cz = cell(pos0[v], 2);
      std::int32_t found = -1;
      for (int dx = -1; dx <= 1 && found < 0; ++dx)
        for (int dy = -1; dy <= 1 && found < 0; ++dy)
          for (int dz = -1; dz <= 1 && found < 0; ++dz) {
            auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
            if (it == grid.end()) continue;
            for (std::int32_t u : it->second)
              if (length(sub(pos[u], pos0[v])) <= tol) {
                found = u;
                break;
              }
          }
      if (found < 0) {
        found = static_cast<std::int32_t>(pos.size());
        pos.push_back(pos0[v]);
        grid[key(cx, cy, cz)].push_back(found);
      }
      weld[v] = found;
    }
  }
  const std::int32_t m = static_cast<std::int32_t>(pos.size());
  std::vector<std::int32_t> tris;
  tris.reserve(mesh.triangles.size());
  for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3) {
    const std::int32_t a = weld[mesh.triangles[t]], b = weld[mesh.triangles[t + 1]], c = weld[mesh.triangles[t + 2]];
    if (a == b || b == c || a == c) continue;
    tris.insert(tris.end(), {a, b, c});
  }

  // Bones.
  const auto segs = bone_segments(sk, params);
  struct Seg {
    V3 a, b;
    std::int32_t joint;
  };
  std::vector<Seg> bones;
  Bvh bvh;
  bvh.build(pos, tris);
  std::vector<std::uint8_t> deforming = params.deforming;
  if (deforming.empty()) {
    // A root joint outside the mesh (Unreal's or Rigify's "root" at the floor)
    // is a control, not a bone: its segments would run through the legs.
    // Outside = fewer than half of the points sampled along its segments
    // (t = 0.1, 0.3, ..., 0.9) are enclosed (every axis ray from the point
    // hits the mesh).
    deforming.assign(static_cast<std::size_t>(nj), 1);
    auto enclosed = [&](const V3& x) {
      for (int a = 0; a < 3; ++a)
        for (double sgn : {-1.0, 1.0}) {
          V3 d{0, 0, 0};
          d[a] = 2 * sgn * diag;
          if (!bvh.hits(x, d)) return false;
        }
      return true;
    };
    // Any other joint whose own point lies outside the mesh and farther from
    // it than kControlGap of the character's size is a control too: an IK
    // pole target in front of the knee, a "Body" hub floating above the
    // back. Left in, it is the nearest *visible* bone of vertices that cannot
    // see their own (a head whose joint sits inside a rigid mech's neck
    // piece) and takes them, where artists give it no weight. Deforming
    // joints lie inside the skin or on it (a foot joint at the sole, a hip
    // under a skirt): on the shared rigs those are at most 0.04 of the
    // diagonal from the nearest vertex, the controls 0.06 or more.
    constexpr double kControlGap = 0.05;
    auto far_outside = [&](const V3& x) {
      if (enclosed(x)) return false;
      double d2 = 1e300;
      for (const V3& q : pos) d2 = std::min(d2, dot(sub(q, x), sub(q, x)));
      return std::sqrt(d2) > kControlGap * diag;
    };
    std::int32_t non_root_controls = 0;
    for (std::int32_t j = 0; j < nj && !tris.empty(); ++j) {
      if (sk.parents[j] >= 0 && !far_outside(to_double(segs[j].front().a))) continue;
      int in = 0, all = 0;
      for (const auto& sg : segs[j]) {
        const V3 a = to_double(sg.a), b = to_double(sg.b);
        for (double t = 0.1; t < 1; t += 0.2, ++all)
          in += enclosed({a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])});
      }
      if (2 * in < all) deforming[j] = 0, non_root_controls += sk.parents[j] >= 0;
    }
    // Most joints outside their mesh means a skeleton that does not fit it
    // (bind matrices offset from the mesh), not a rig of controls: then
    // only the roots' rule holds.
    if (2 * non_root_controls > nj)
      for (std::int32_t j = 0; j < nj; ++j) deforming[j] = deforming[j] || sk.parents[j] >= 0;
    std::int32_t kept = 0;
    for (auto x : deforming) kept += x;
    if (kept == 0) std::fill(deforming.begin(), deforming.end(), 1);  // only controls: use them
  }
  for (std::size_t j = 0; j < params.joint_override.size(); ++j)
    if (params.joint_override[j] != 0) deforming[j] = params.joint_override[j] > 0;
  // A segment that ends at a control (a root's segment to a pole target
  // hanging off it) is not a bone either; a joint left with none keeps its
  // point.
  std::vector<Vec3> control_heads;
  for (std::int32_t j = 0; j < nj; ++j)
    if (!deforming[j]) control_heads.push_back(segs[j].front().a);
  for (std::int32_t j = 0; j < nj; ++j) {
    if (!deforming[j]) continue;
    const std::size_t before = bones.size();
    for (const auto& s : segs[j])
      if (std::find(control_heads.begin(), control_heads.end(), s.b) == control_heads.end())
        bones.push_back({to_double(s.a), to_double(s.b), j});
    if (bones.size() == before) bones.push_back({to_double(segs[j].front().a), to_double(segs[j].front().a), j});
  }
  GATCORE_CHECK(!bones.empty(), ch.name, ": bone heat: no joint deforms");

  // Cotangent Laplacian (clamped) and lumped areas.
  std::vector<double> area(static_cast<std::size_t>(m), 0.0);
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(tris.size() * 4);
  std::vector<double> diagL(static_cast<std::size_t>(m), 0.0);
  for (std::size_t t = 0; t < tris.size(); t += 3) {
    const std::int32_t id[3] = {tris[t], tris[t + 1], tris[t + 2]};
    const double a2 = length(cross(sub(pos[id[1]], pos[id[0]]), sub(pos[id[2]], pos[id[0]])));
    for (int k = 0; k < 3; ++k) area[id[k]] += a2 / 6.0;
    for (int k = 0; k < 3; ++k) {
      // Angle at id[k] is opposite edge (id[k+1], id[k+2]).
      const std::int32_t o = id[k], i = id[(k + 1) % 3], j = id[(k + 2) % 3];
      const V3 u = sub(pos[i], pos[o]), w = sub(pos[j], pos[o]);
      const double s = length(cross(u, w));
      const double cot = s > 0 ? std::clamp(dot(u, w) / s, 0.0, 1e3) : 1e3 * (dot(u, w) > 0);
      const double x = 0.5 * cot;
      if (x == 0) continue;
      trip.push_back({i, j, -x});
      trip.push_back({j, i, -x});
      diagL[i] += x;
      diagL[j] += x;
    }
  }
  double mean_area = 0;
  std::int32_t with_area = 0;
  for (double a : area)
    if (a > 0) mean_area += a, ++with_area;
  mean_area = with_area ? mean_area / with_area : 1.0;
  for (auto& a : area)
    if (!(a > 0)) a = mean_area;

  // Nearest (visible) bone per vertex.
  const double dmin = 1e-4 * diag;  // vertices on a bone: finite heat
  std::vector<double> h(static_cast<std::size_t>(m), 0.0);
  std::vector<std::vector<std::pair<std::int32_t, double>>> target(static_cast<std::size_t>(m));
  std::vector<double> nearest_any(static_cast<std::size_t>(m));
  std::vector<std::vector<std::pair<std::int32_t, double>>> target_any(static_cast<std::size_t>(m));
  // Bones that tie for nearest share the vertex (Pinocchio's rule: within a
  // factor 1 + kTie of the nearest). Past that a bone's share falls linearly
  // to 0 at 1 + 2 kTie, so that a vertex on an exact tie (an edge loop
  // snapped to a joint, a procedural ring) gets the same targets whichever
  // way float rounding tips the distances, in any frame.
  constexpr double kTie = 1e-4;
  auto ties = [&](const std::vector<std::pair<double, std::int32_t>>& c, std::size_t first, double d,
                  std::vector<std::pair<std::int32_t, double>>& out) {
    // Distances under dmin (a vertex on a bone) are all "on it".
    const double full = std::max(d, dmin) * (1 + kTie), none = std::max(d, dmin) * (1 + 2 * kTie);
    std::vector<std::pair<std::int32_t, double>> js;
    double sum = 0;
    for (std::size_t k = first; k < c.size() && std::max(c[k].first, dmin) < none; ++k) {
      const double share = std::min(1.0, (none - std::max(c[k].first, dmin)) / (none - full));
      const std::int32_t j = bones[c[k].second].joint;
      auto it = std::find_if(js.begin(), js.end(), [&](const auto& e) { return e.first == j; });
      if (it == js.end()) {
        js.push_back({j, share});
        sum += share;
      } else if (share > it->second) {
        sum += share - it->second;
        it->second = share;
      }
    }
    for (const auto& [j, share] : js) out.push_back({j, share / sum});
  };
  // Vertex normals (the sum of the unit normals of the vertex's triangles),
  // for facing_distance.
  std::vector<V3> normal(static_cast<std::size_t>(m), V3{0, 0, 0});
  if (params.facing_distance) {
    for (std::size_t t = 0; t < tris.size(); t += 3) {
      V3 f = cross(sub(pos[tris[t + 1]], pos[tris[t]]), sub(pos[tris[t + 2]], pos[tris[t]]));
      const double l = length(f);
      if (!(l > 0)) continue;
      for (double& x : f) x /= l;
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) normal[tris[t + k]][c] += f[c];
    }
    for (V3& nv : normal) {
      const double l = length(nv);
      if (l > 0)
        for (double& x : nv) x /= l;
    }
  }
  std::vector<std::pair<double, std::int32_t>> cand;
  std::vector<V3> closest(bones.size());
  for (std::int32_t v = 0; v < m; ++v) {
    cand.clear();
    for (std::size_t b = 0; b < bones.size(); ++b) {
      double past = 0;
      closest[b] = closest_on_segment(pos[v], bones[b].a, bones[b].b, &past);
      // Past a bone's tail the vertex is as near to the child's head: the
      // child (a leaf foot beyond the shin's end) wins the tie. The handicap
      // grows over the first 1e-3 of the diagonal past the tail, so a vertex
      // on the joint's plane is not tipped one way or the other by rounding.
      const V3 out = sub(pos[v], closest[b]);
      double d = length(out);
      // facing_distance: a bone on the side the surface faces (the normal
      // points at it: an arm seen from the chest under it, a leg from the
      // inside of the other) is that much farther, (1 + cos) / 2 with cos
      // between the normal and the direction from the bone to the vertex.
      if (params.facing_distance && d > 0 && dot(normal[v], normal[v]) > 0)
        d /= 0.5 * (dot(out, normal[v]) / d + 1.001);
      const double r = std::min(1.0, past / (1e-3 * diag));
      cand.push_back({d * (1 + 1e-3 * r) + 1e-9 * diag * r, static_cast<std::int32_t>(b)});
    }
    std::sort(cand.begin(), cand.end());
    nearest_any[v] = std::max(cand[0].first, dmin);
    ties(cand, 0, cand[0].first, target_any[v]);
    // Blender's rule (nearest_only): only the nearest bones heat a vertex,
    // and only when it sees them; a vertex whose nearest bone is hidden
    // (behind an overlapping part) gets heat by diffusion alone, not from a
    // farther bone it happens to see.
    const double reach = std::max(cand[0].first, dmin) * (1 + 2 * kTie);
    for (std::size_t k = 0; k < cand.size(); ++k) {
      if (params.nearest_only && std::max(cand[k].first, dmin) >= reach) break;
      if (params.visibility && bvh.blocked(pos[v], closest[cand[k].second], v)) continue;
      const double d = std::max(cand[k].first, dmin);
      h[v] = params.heat / (d * d);
      ties(cand, k, cand[k].first, target[v]);
      // Ties are only counted among visible bones at the same distance;
      // invisible ones at that distance would be rare and are kept (cheap).
      break;
    }
  }
  // Components (union-find over triangles) with no heated vertex: nearest bones regardless of visibility.
  std::vector<std::int32_t> uf(static_cast<std::size_t>(m));
  std::iota(uf.begin(), uf.end(), 0);
  auto find = [&](std::int32_t x) {
    while (uf[x] != x) x = uf[x] = uf[uf[x]];
    return x;
  };
  for (std::size_t t = 0; t < tris.size(); t += 3)
    for (int k = 1; k < 3; ++k) {
      const std::int32_t a = find(tris[t]), b = find(tris[t + k]);
      if (a != b) uf[a] = b;
    }
  std::vector<std::uint8_t> heated(static_cast<std::size_t>(m), 0);
  for (std::int32_t v = 0; v < m; ++v)
    if (h[v] > 0) heated[find(v)] = 1;
  for (std::int32_t v = 0; v < m; ++v)
    if (!heated[find(v)]) {
      h[v] = params.heat / (nearest_any[v] * nearest_any[v]);
      target[v] = target_any[v];
    }

  // (L + M H) W = M H P, one factorisation.
  for (std::int32_t v = 0; v < m; ++v) trip.push_back({v, v, diagL[v] + area[v] * h[v]});
  Eigen::SparseMatrix<double> A(m, m);
  A.setFromTriplets(trip.begin(), trip.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(A);
  GATCORE_CHECK(ldlt.info() == Eigen::Success, ch.name, ": bone heat: the heat system could not be factorised");
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(m, nj);
  for (std::int32_t v = 0; v < m; ++v)
    for (const auto& [j, p] : target[v]) rhs(v, j) += area[v] * h[v] * p;
  const Eigen::MatrixXd W = ldlt.solve(rhs);
  GATCORE_CHECK(ldlt.info() == Eigen::Success && W.allFinite(), ch.name, ": bone heat: the heat solve failed");

  const double cut = params.cut_below, ramp = params.ramp_until;
  auto limited = [&](double w) {
    if (cut <= 0) return w;
    if (w < cut) return 0.0;
    if (w < ramp) return (w - cut) / (ramp - cut) * ramp;
    return w;
  };
  SkinWeights raw;
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int32_t u = weld[v];
    double best = 0;
    std::int32_t best_j = -1;
    for (std::int32_t j = 0; j < nj; ++j)
      if (W(u, j) > best) best = W(u, j), best_j = j;
    for (std::int32_t j = 0; j < nj; ++j) {
      const double w = limited(W(u, j));
      if (w > 1e-9 * best && w > 0) {
        raw.joint.push_back(j);
        raw.weight.push_back(static_cast<float>(w));
      }
    }
    if (raw.joint.size() == static_cast<std::size_t>(raw.ptr.back())) {
      // Nothing left: the largest heat (every weight under the cut: a vertex
      // far from all bones), else the nearest bone (nothing positive).
      raw.joint.push_back(best_j >= 0 ? best_j : target_any[u].front().first);
      raw.weight.push_back(1.0f);
    }
    raw.ptr.push_back(static_cast<std::int64_t>(raw.joint.size()));
  }
  return limit_weights(raw, params.max_influences, params.min_weight);
}

SkinWeights mix_with_bone_heat(const Character& ch, const SkinWeights& model, float share,
                               const BoneHeatParams& params) {
  if (share == 0.0f) return model;
  return blend_weights(model, bone_heat_weights(ch, params), share, params.max_influences);
}

}  // namespace gatcore::character
