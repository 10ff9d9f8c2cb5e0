// LBS, DQS, normals, Delta Mush on generated tubes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace {

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// Enclosed volume of a closed, consistently oriented triangle mesh.
double volume(const std::vector<float>& p, const std::vector<std::int32_t>& t) {
  double v = 0.0;
  for (std::size_t k = 0; k < t.size(); k += 3) {
    const float *a = &p[3 * t[k]], *b = &p[3 * t[k + 1]], *c = &p[3 * t[k + 2]];
    v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0;
  }
  return v;
}

// Largest angle (radians) between the normals of two triangles sharing an
// edge whose ends are both in `keep`.
double max_dihedral(const std::vector<float>& p, const std::vector<std::int32_t>& t, const std::vector<char>& keep) {
  std::map<std::pair<int, int>, std::vector<std::size_t>> faces;
  std::vector<std::array<double, 3>> fn(t.size() / 3);
  for (std::size_t f = 0; f < t.size() / 3; ++f) {
    const float *a = &p[3 * t[3 * f]], *b = &p[3 * t[3 * f + 1]], *c = &p[3 * t[3 * f + 2]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    std::array<double, 3> n = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& x : n) x /= l;
    fn[f] = n;
    for (int e = 0; e < 3; ++e) {
      const int i = t[3 * f + e], j = t[3 * f + (e + 1) % 3];
      faces[{std::min(i, j), std::max(i, j)}].push_back(f);
    }
  }
  double m = 0.0;
  for (const auto& [e, fs] : faces)
    if (fs.size() == 2 && keep[e.first] && keep[e.second]) {
      const auto &a = fn[fs[0]], &b = fn[fs[1]];
      m = std::max(m, std::acos(std::clamp(a[0] * b[0] + a[1] * b[1] + a[2] * b[2], -1.0, 1.0)));
    }
  return m;
}

Pose twist(const Skeleton& s, float radians) {
  Pose p = rest_pose(s);
  p.local[1].rotation = quat_from_axis_angle({0.0f, 1.0f, 0.0f}, radians);
  return p;
}

}  // namespace

TEST_CASE("skinning the rest pose reproduces the rest mesh", "[character][deform]") {
  const Character ch = charfix::tube_character();
  const auto S = skinning_matrices(ch.skeleton, rest_pose(ch.skeleton));
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, S), ch.mesh.positions) < 1e-6f);
  CHECK(max_abs_diff(dual_quaternion_skinning(ch.mesh, S), ch.mesh.positions) < 1e-5f);
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bind_pose(ch.skeleton))),
                     ch.mesh.positions) < 1e-5f);
}

TEST_CASE("LBS and DQS agree on a rigid rotation of the root", "[character][deform]") {
  const Character ch = charfix::tube_character();
  Pose p = rest_pose(ch.skeleton);
  p.local[0].rotation = quat_from_axis_angle({0.3f, 0.2f, 1.0f}, 1.1f);
  p.local[0].translation = {0.5f, -1.0f, 2.0f};
  const auto S = skinning_matrices(ch.skeleton, p);
  CHECK(max_abs_diff(linear_blend_skinning(ch.mesh, S), dual_quaternion_skinning(ch.mesh, S)) < 1e-5f);
}

TEST_CASE("LBS and DQS agree where one bone rotates and its weights are 1", "[character][deform]") {
  const Character ch = charfix::tube_character();
  const Pose p = twist(ch.skeleton, 1.3f);
  const auto S = skinning_matrices(ch.skeleton, p);
  const auto lbs = linear_blend_skinning(ch.mesh, S), dqs = dual_quaternion_skinning(ch.mesh, S);
  const auto& W = ch.mesh.weights;
  int rigid = 0;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    if (W.ptr[v + 1] - W.ptr[v] != 1) continue;
    ++rigid;
    for (int c = 0; c < 3; ++c) CHECK(lbs[3 * v + c] == Approx(dqs[3 * v + c]).margin(1e-5));
  }
  CHECK(rigid > 100);
}

TEST_CASE("DQS keeps the volume of a twisted tube where LBS collapses", "[character][deform]") {
  const Character ch = charfix::tube_character(40, 32);
  const double v0 = volume(ch.mesh.positions, ch.mesh.triangles);
  REQUIRE(v0 > 0.0);
  const auto S = skinning_matrices(ch.skeleton, twist(ch.skeleton, 2.6f));  // ~150 degrees
  const double vl = volume(linear_blend_skinning(ch.mesh, S), ch.mesh.triangles);
  const double vd = volume(dual_quaternion_skinning(ch.mesh, S), ch.mesh.triangles);
  CHECK(vl < 0.85 * v0);                      // candy-wrapper collapse
  CHECK(std::abs(vd - v0) < 0.02 * v0);       // DQS: a pure twist keeps radii
  CHECK(std::abs(vd - v0) < 0.2 * std::abs(vl - v0));
}

TEST_CASE("area-weighted vertex normals", "[character][deform]") {
  // A unit square split into a large and a small triangle, both facing +z,
  // and a vertex in no triangle.
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 5, 5, 5};
  const std::vector<std::int32_t> t = {0, 1, 2, 0, 2, 3};
  const auto n = vertex_normals(p, t);
  for (int v = 0; v < 4; ++v) CHECK(n[3 * v + 2] == Approx(1.0f));
  CHECK(n[12] == 0.0f);
  CHECK(n[13] == 0.0f);
  CHECK(n[14] == 0.0f);
  // A tent: a big face tilted one way and a small face the other; the normal
  // of the shared vertex leans toward the big face.
  const std::vector<float> q = {0, 0, 0, 0, 1, 0, 4, 0, 1, -1, 0, 1};
  const std::vector<std::int32_t> u = {0, 2, 1, 0, 1, 3};
  const auto m = vertex_normals(q, u);
  const float big = std::abs(m[0] - (-0.2425f)), small = std::abs(m[0] - 0.7071f);
  CHECK(big < small);
  // Sphere-like closed tube: normals unit length.
  const Character ch = charfix::tube_character();
  const auto nn = vertex_normals(ch.mesh.positions, ch.mesh.triangles);
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v)
    CHECK(std::sqrt(nn[3 * v] * nn[3 * v] + nn[3 * v + 1] * nn[3 * v + 1] + nn[3 * v + 2] * nn[3 * v + 2]) ==
          Approx(1.0f).margin(1e-5));
}

TEST_CASE("Delta Mush: rest pose is the rest mesh, rigid motions stay rigid, a bend keeps volume", "[character][deform]") {
  const Character ch = charfix::tube_character(41, 24, 2.0f, 0.25f, 0.1f);
  DeltaMushParams prm;
  prm.iterations = 40;
  prm.step = 0.5f;
  const DeltaMush dm = delta_mush_bind(ch.mesh, prm);
  const auto rest = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, rest_pose(ch.skeleton)));
  CHECK(max_abs_diff(delta_mush_apply(dm, rest), ch.mesh.positions) < 1e-5f);
  // A rigid motion of the whole mesh moves Delta Mush rigidly too.
  Pose rigid = rest_pose(ch.skeleton);
  rigid.local[0].rotation = quat_from_axis_angle({1.0f, 0.0f, 0.0f}, 0.7f);
  const auto lr = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, rigid));
  CHECK(max_abs_diff(delta_mush_apply(dm, lr), lr) < 1e-4f);
  // Bent 60 degrees with near-rigid weights: LBS folds at the elbow, Delta Mush
  // smooths the crease away.
  Pose p = rest_pose(ch.skeleton);
  p.local[1].rotation = quat_from_axis_angle({0.0f, 0.0f, 1.0f}, 1.0f);
  const auto lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, p));
  const auto mush = delta_mush_apply(dm, lbs);
  const double v0 = volume(ch.mesh.positions, ch.mesh.triangles);
  std::vector<char> mid(static_cast<std::size_t>(ch.mesh.num_vertices()));  // away from the caps
  for (std::size_t v = 0; v < mid.size(); ++v) mid[v] = std::abs(ch.mesh.positions[3 * v + 1] - 1.0f) < 0.5f;
  const double d0 = max_dihedral(ch.mesh.positions, ch.mesh.triangles, mid);
  const double dl = max_dihedral(lbs, ch.mesh.triangles, mid), dm_ = max_dihedral(mush, ch.mesh.triangles, mid);
  INFO("max dihedral: rest " << d0 << " LBS " << dl << " Delta Mush " << dm_);
  CHECK(dl > 2.0 * d0);
  CHECK(dm_ < 0.75 * dl);
  // Volume stays within a few percent of the rest volume.
  CHECK(std::abs(volume(mush, ch.mesh.triangles) - v0) < 0.1 * v0);
  CHECK_THROWS(delta_mush_bind(ch.mesh, DeltaMushParams{-1, 0.5f}));
  CHECK_THROWS(delta_mush_apply(dm, std::vector<float>(3)));
}

TEST_CASE("skin_vectors is LBS's blended linear part: LBS(p + d) - LBS(p)", "[character][deform]") {
  const Character ch = charfix::tube_character();
  Pose p = twist(ch.skeleton, 0.9f);
  p.local[0].translation = {0.4f, -0.2f, 1.0f};  // translation must not reach the vectors
  const auto S = skinning_matrices(ch.skeleton, p);
  std::vector<float> d(ch.mesh.positions.size());
  for (std::size_t i = 0; i < d.size(); ++i) d[i] = 0.01f * std::sin(0.37f * float(i));
  Mesh moved = ch.mesh;
  for (std::size_t i = 0; i < d.size(); ++i) moved.positions[i] += d[i];
  const auto lbs = linear_blend_skinning(ch.mesh, S), lbs_moved = linear_blend_skinning(moved, S);
  std::vector<float> expect(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) expect[i] = lbs_moved[i] - lbs[i];
  CHECK(max_abs_diff(skin_vectors(ch.mesh, S, d), expect) < 1e-5f);
  CHECK_THROWS_AS(skin_vectors(ch.mesh, S, std::vector<float>(6)), gatcore::InvalidArgument);
}

TEST_CASE("laplacian_details against a plain double-precision smoothing", "[character][deform]") {
  const Character ch = charfix::tube_character(8, 10);
  const DeltaMush dm = delta_mush_bind(ch.mesh, {0, 0.5f});
  const std::vector<float>& x = ch.mesh.positions;
  const std::size_t n = x.size() / 3;
  std::vector<double> s(x.begin(), x.end());
  std::vector<std::vector<double>> want;
  for (int it = 1; it <= 5; ++it) {
    std::vector<double> t = s;
    for (std::size_t v = 0; v < n; ++v) {
      const auto k0 = dm.adj_ptr[v], k1 = dm.adj_ptr[v + 1];
      for (int c = 0; c < 3; ++c) {
        double m = 0.0;
        for (auto k = k0; k < k1; ++k) m += s[3 * std::size_t(dm.adj[std::size_t(k)]) + c];
        t[3 * v + c] = s[3 * v + c] + 0.5 * (m / double(k1 - k0) - s[3 * v + c]);
      }
    }
    s = t;
    if (it == 2 || it == 5) {
      std::vector<double> d(x.size());
      for (std::size_t i = 0; i < d.size(); ++i) d[i] = x[i] - s[i];
      want.push_back(d);
    }
  }
  const auto got = laplacian_details(dm, x, std::vector{2, 5});
  REQUIRE(got.size() == 2);
  double worst = 0.0, size = 0.0;
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t i = 0; i < x.size(); ++i) {
      worst = std::max(worst, std::abs(double(got[k][i]) - want[k][i]));
      size = std::max(size, std::abs(want[k][i]));
    }
  CHECK(size > 1e-3);  // a tube's rings are curved: the details are not zero
  CHECK(worst < 1e-5);
  CHECK_THROWS_AS(laplacian_details(dm, x, std::vector{5, 2}), gatcore::InvalidArgument);
  CHECK_THROWS_AS(laplacian_details(dm, x, std::vector{0}), gatcore::InvalidArgument);
}

TEST_CASE("distortion scales parse, format and name bad values", "[character][deform]") {
  CHECK(parse_distortion_scales("1,4,16", "--x") == std::vector{1, 4, 16});
  CHECK(parse_distortion_scales("none", "--x").empty());
  CHECK(parse_distortion_scales("", "--x").empty());
  CHECK(format_distortion_scales(std::vector{1, 4, 16}) == "1,4,16");
  CHECK(format_distortion_scales(std::vector<int>{}).empty());
  for (const char* bad : {"1,,4", "4,1", "0", "a", "1,", "2,2", "3x", "2000"}) {
    INFO(bad);
    try {
      parse_distortion_scales(bad, "--distortion-scales");
      FAIL("accepted");
    } catch (const gatcore::InvalidArgument& e) {
      CHECK(std::string(e.what()).find("--distortion-scales") != std::string::npos);
    }
  }
}
