// Node features, normalisation, geodesic k-nearest vertices.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/io/gltf.hpp"

using namespace gatcore::character;

namespace {

// Full Dijkstra distances from `src` (brute-force reference: O(n^2) scan).
std::vector<double> all_distances(const std::vector<float>& p, const std::vector<std::int32_t>& t, int src) {
  const int n = static_cast<int>(p.size() / 3);
  std::vector<std::vector<std::pair<int, double>>> adj(n);
  for (std::size_t f = 0; f < t.size(); f += 3)
    for (int e = 0; e < 3; ++e) {
      const int a = t[f + e], b = t[f + (e + 1) % 3];
      const double d = std::sqrt(std::pow(p[3 * a] - p[3 * b], 2) + std::pow(p[3 * a + 1] - p[3 * b + 1], 2) +
                                 std::pow(p[3 * a + 2] - p[3 * b + 2], 2));
      adj[a].push_back({b, d});
      adj[b].push_back({a, d});
    }
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  std::vector<char> done(n, 0);
  dist[src] = 0.0;
  for (int it = 0; it < n; ++it) {
    int u = -1;
    for (int v = 0; v < n; ++v)
      if (!done[v] && (u < 0 || dist[v] < dist[u])) u = v;
    if (u < 0 || std::isinf(dist[u])) break;
    done[u] = 1;
    for (auto [w, d] : adj[u]) dist[w] = std::min(dist[w], dist[u] + d);
  }
  return dist;
}

}  // namespace

TEST_CASE("geodesic kNN matches a brute-force Dijkstra, never crosses components", "[character][features]") {
  // Two jittered grids (disjoint components) of 12x10 and 4x3 vertices.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jit(-0.2f, 0.2f);
  std::vector<float> p;
  std::vector<std::int32_t> t;
  auto grid = [&](int nx, int ny, float x0) {
    const int base = static_cast<int>(p.size() / 3);
    for (int y = 0; y < ny; ++y)
      for (int x = 0; x < nx; ++x) p.insert(p.end(), {x0 + x + jit(rng), y + jit(rng), jit(rng)});
    for (int y = 0; y + 1 < ny; ++y)
      for (int x = 0; x + 1 < nx; ++x) {
        const int a = base + y * nx + x;
        t.insert(t.end(), {a, a + 1, a + nx, a + 1, a + nx + 1, a + nx});
      }
  };
  grid(12, 10, 0.0f);
  grid(4, 3, 1.5f);  // overlaps the first in space: Euclidean neighbours would mix
  const int n = static_cast<int>(p.size() / 3), k = 16;
  const auto lists = geodesic_knn_lists(p, t, k);
  REQUIRE(static_cast<int>(lists.size()) == n);
  for (int v = 0; v < n; ++v) {
    const auto d = all_distances(p, t, v);
    std::vector<int> order(n);
    for (int i = 0; i < n; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return d[a] < d[b]; });
    const int reachable = static_cast<int>(std::count_if(d.begin(), d.end(), [](double x) { return !std::isinf(x); }));
    const int expect = std::min(k, reachable);
    REQUIRE(static_cast<int>(lists[v].size()) == expect);
    CHECK(lists[v][0] == v);
    std::set<int> got(lists[v].begin(), lists[v].end()), ref(order.begin(), order.begin() + expect);
    CHECK(got == ref);
    for (std::size_t i = 1; i < lists[v].size(); ++i) CHECK(d[lists[v][i - 1]] <= d[lists[v][i]] + 1e-6);
  }
  const gatcore::CsrGraph g = geodesic_knn(p, t, k);
  CHECK(g.num_nodes == n);
  CHECK(g.degree(0) == k);
  CHECK(g.degree(n - 1) == 12);  // the small component has 12 vertices
  CHECK_THROWS(geodesic_knn(p, t, 0));
}

TEST_CASE("DenseGATs and NeuroSkinning node features", "[character][features]") {
  const Character ch = charfix::tube_character(8, 8);
  const auto normals = vertex_normals(ch.mesh.positions, ch.mesh.triangles);
  const auto joints = joint_positions(global_transforms(ch.skeleton, rest_pose(ch.skeleton)));
  REQUIRE(joints.size() == 2);
  const auto x = densegats_features(ch.mesh.positions, normals, joints);
  REQUIRE(x.rows() == ch.mesh.num_vertices());
  REQUIRE(x.cols() == 6 + 2);
  for (std::int64_t v = 0; v < x.rows(); ++v) {
    for (int c = 0; c < 3; ++c) {
      CHECK(x.at(v, c) == ch.mesh.positions[3 * v + c]);
      CHECK(x.at(v, 3 + c) == normals[3 * v + c]);
    }
    const float* p = &ch.mesh.positions[3 * v];
    CHECK(x.at(v, 6) == Approx(std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])));
    CHECK(x.at(v, 7) == Approx(std::sqrt(p[0] * p[0] + (p[1] - 1) * (p[1] - 1) + p[2] * p[2])));
  }
  // Bones: root spans (0,0,0)-(0,1,0); bone1 is a leaf (its point (0,1,0)).
  const auto y = neuroskinning_features(ch.mesh.positions, normals, joints, ch.skeleton.parents);
  REQUIRE(y.cols() == 8);
  for (std::int64_t v = 0; v < y.rows(); ++v) {
    const float* p = &ch.mesh.positions[3 * v];
    const float r = std::sqrt(p[0] * p[0] + p[2] * p[2]);
    const float d0 = p[1] <= 0 ? std::sqrt(r * r + p[1] * p[1]) : p[1] >= 1 ? std::sqrt(r * r + (p[1] - 1) * (p[1] - 1)) : r;
    CHECK(y.at(v, 6) == Approx(d0).margin(1e-5));
    CHECK(y.at(v, 7) == Approx(std::sqrt(r * r + (p[1] - 1) * (p[1] - 1))).margin(1e-5));
  }
  CHECK_THROWS(densegats_features(ch.mesh.positions, std::vector<float>(3), joints));
}

TEST_CASE("normalisation: origin bone at 0, height 1, file orientation undone", "[character][features]") {
  // The tube with its bind space rotated and scaled the way FBX2glTF exports
  // are (Z-up, x100); the inverse bind matrices undo it, so the world rest
  // pose is the Y-up tube again.
  Character ch = charfix::tube_character(8, 8);
  ch.skeleton.names[0] = "Hips";
  const Mat4 zup = to_matrix(Transform{{0, 0, 0}, quat_from_axis_angle({1, 0, 0}, 1.5707963f), {100, 100, 100}});
  const Mat4 back = inverse(zup);
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    const Vec3 q = transform_point(zup, {ch.mesh.positions[3 * v], ch.mesh.positions[3 * v + 1], ch.mesh.positions[3 * v + 2]});
    for (int c = 0; c < 3; ++c) ch.mesh.positions[3 * v + c] = q[c];
  }
  for (auto& ibm : ch.skeleton.inverse_bind) ibm = mul(ibm, back);
  const NormalisationStats st = compute_normalisation(ch);
  CHECK(st.origin_joint == 0);
  const auto p = normalise_bind_positions(st, ch.mesh.positions);
  float lo = 1e9f, hi = -1e9f;
  for (std::size_t v = 0; v < p.size() / 3; ++v) {
    lo = std::min(lo, p[3 * v + 1]);
    hi = std::max(hi, p[3 * v + 1]);
  }
  CHECK(hi - lo == Approx(1.0f));
  CHECK(lo == Approx(0.0f).margin(1e-5));  // the origin bone is at the tube's bottom
  const auto j = normalised_bind_joints(st, ch.skeleton);
  CHECK(j[0][0] == Approx(0.0f).margin(1e-5));
  CHECK(j[0][1] == Approx(0.0f).margin(1e-5));
  CHECK(j[1][1] == Approx(0.5f).margin(1e-5));  // +Y is up again
}

TEST_CASE("features of a real character", "[character][features][data]") {
  const auto dir = charfix::data_dir();
  const auto path = dir / "characters" / "quaternius" / "modular_men" / "Farmer.glb";
  if (dir.empty() || !std::filesystem::exists(path)) {
    WARN("SKIPPED: data not found (" << path << ")");
    return;
  }
  const Character ch = load_gltf(path.string());
  const NormalisationStats st = compute_normalisation(ch);
  CHECK(ch.skeleton.names[st.origin_joint].find("ips") != std::string::npos);
  const auto p = normalise_bind_positions(st, ch.mesh.positions);
  float lo = 1e9f, hi = -1e9f;
  for (std::size_t v = 0; v < p.size() / 3; ++v) {
    lo = std::min(lo, p[3 * v + 1]);
    hi = std::max(hi, p[3 * v + 1]);
  }
  CHECK(hi - lo == Approx(1.0f));
  CHECK(lo < -0.3f);  // hips at the origin: the feet are well below
  const auto normals = vertex_normals(p, ch.mesh.triangles);
  const auto x = neuroskinning_features(p, normals, normalised_bind_joints(st, ch.skeleton), ch.skeleton.parents);
  CHECK(x.rows() == ch.mesh.num_vertices());
  CHECK(x.cols() == 6 + 49);
  x.check_finite("features");
  const auto g = geodesic_knn(p, ch.mesh.triangles, 16);
  CHECK(g.num_nodes == ch.mesh.num_vertices());
}
