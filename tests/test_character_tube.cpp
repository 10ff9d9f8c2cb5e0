// The procedural two-bone tube (character/data/tube.hpp) and the embedded
// tube data built on it (character/data/tube_data.hpp).
#include <catch2/catch.hpp>

#include <cmath>

#include "gatcore/character/data/tube.hpp"
#include "gatcore/character/data/tube_data.hpp"
#include "gatcore/character/rig/vec3.hpp"

using namespace gatcore;
using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

Vec3 at(const TubeMesh& t, std::int64_t v) {
  return {t.positions[std::size_t(3 * v)], t.positions[std::size_t(3 * v + 1)], t.positions[std::size_t(3 * v + 2)]};
}

// Signs of (face normal . outward radial direction) over the side faces.
void count_facing(const TubeMesh& t, int& out, int& in) {
  out = in = 0;
  for (std::size_t k = 0; k < t.triangles.size(); k += 3) {
    const Vec3 a = at(t, t.triangles[k]), b = at(t, t.triangles[k + 1]), c = at(t, t.triangles[k + 2]);
    const Vec3 centre = scale(add(add(a, b), c), 1.0f / 3.0f);
    const Vec3 radial{centre[0], 0.0f, centre[2]};
    const float d = dot(cross(sub(b, a), sub(c, a)), radial);
    (d > 0 ? out : in) += 1;
  }
}

}  // namespace

TEST_CASE("tube: grid, seam and caps", "[character][tube]") {
  TubeOptions o;
  o.rings = 5, o.segments = 6;
  const TubeMesh plain = tube_mesh(o);
  CHECK(plain.num_vertices() == 30);
  CHECK(plain.positions.size() == 90);
  CHECK(plain.triangles.size() == std::size_t(3 * 2 * 4 * 6));
  for (std::int32_t i : plain.triangles) CHECK((i >= 0 && i < 30));
  for (std::int64_t v = 0; v < plain.num_vertices(); ++v) {
    const Vec3 p = at(plain, v);
    CHECK(std::hypot(p[0], p[2]) == Approx(0.25f).margin(1e-6));
    CHECK(p[1] == Approx(2.0f * float(v / 6) / 4.0f).margin(1e-6));
  }
  o.seam = true;
  const TubeMesh seam = tube_mesh(o);
  CHECK(seam.num_vertices() == 35);  // the first column repeated as the last
  for (int r = 0; r < 5; ++r) CHECK(at(seam, 7 * r + 6) == at(seam, 7 * r));
  o.seam = false, o.caps = true;
  const TubeMesh capped = tube_mesh(o);
  CHECK(capped.num_vertices() == 32);
  CHECK(capped.triangles.size() == plain.triangles.size() + std::size_t(3 * 2 * 6));
  CHECK(at(capped, 30) == Vec3{0.0f, 0.0f, 0.0f});
  CHECK(at(capped, 31) == Vec3{0.0f, 2.0f, 0.0f});
  CHECK(capped.bone1_weight[30] == 0.0f);
  CHECK(capped.bone1_weight[31] == 1.0f);
}

TEST_CASE("tube: windings face out or in", "[character][tube]") {
  TubeOptions o;
  o.rings = 6, o.segments = 8;
  int out = 0, in = 0;
  count_facing(tube_mesh(o), out, in);
  CHECK(out == 2 * 5 * 8);
  CHECK(in == 0);
  o.winding = TubeWinding::inward;
  count_facing(tube_mesh(o), out, in);
  CHECK(out == 0);
  CHECK(in == 2 * 5 * 8);
  // The two windings split each quad along different diagonals.
  TubeOptions p = o;
  p.winding = TubeWinding::outward;
  CHECK(tube_mesh(o).triangles != tube_mesh(p).triangles);
}

TEST_CASE("tube: weights blend around the middle", "[character][tube]") {
  TubeOptions o;
  o.rings = 41, o.segments = 4, o.blend = 0.3f;  // y = 0.05 k
  const TubeMesh lin = tube_mesh(o);
  o.falloff = TubeFalloff::smoothstep;
  const TubeMesh smooth = tube_mesh(o);
  for (int r = 0; r < 41; ++r) {
    const float y = 0.05f * float(r);
    const float wl = lin.bone1_weight[std::size_t(4 * r)], ws = smooth.bone1_weight[std::size_t(4 * r)];
    if (y < 0.69f) CHECK((wl == 0.0f && ws == 0.0f));
    if (y > 1.31f) CHECK((wl == 1.0f && ws == 1.0f));
    if (y > 0.71f && y < 1.29f) {
      const float t = (y - 0.7f) / 0.6f;
      CHECK(wl == Approx(t).margin(1e-5));
      CHECK(ws == Approx(t * t * (3 - 2 * t)).margin(1e-5));
    }
    for (int s = 1; s < 4; ++s) CHECK(lin.bone1_weight[std::size_t(4 * r + s)] == wl);  // per ring
  }
  CHECK(smooth.bone1_weight[std::size_t(4 * 20)] == Approx(0.5f));
  o.falloff = TubeFalloff::linear, o.blend = 0.0f;
  const TubeMesh step = tube_mesh(o);
  CHECK(step.bone1_weight[std::size_t(4 * 19)] == 0.0f);
  CHECK(step.bone1_weight[std::size_t(4 * 20)] == 1.0f);
}

TEST_CASE("tube: an elliptic section", "[character][tube]") {
  TubeOptions o;
  o.rings = 2, o.segments = 4, o.depth = 0.6f;
  const TubeMesh t = tube_mesh(o);
  CHECK(at(t, 0)[0] == Approx(0.25f));
  CHECK(at(t, 1)[2] == Approx(0.15f));
  CHECK(at(t, 3)[2] == Approx(-0.15f));
}

TEST_CASE("tube: bad options name themselves", "[character][tube]") {
  TubeOptions o;
  o.rings = 1;
  CHECK_THROWS_WITH(tube_mesh(o), Contains("rings must be >= 2, got 1"));
  o = {};
  o.segments = 2;
  CHECK_THROWS_WITH(tube_mesh(o), Contains("segments must be >= 3, got 2"));
  o = {};
  o.radius = 0.0f;
  CHECK_THROWS_WITH(tube_mesh(o), Contains("length, radius and depth must be > 0"));
  o = {};
  o.blend = 1.5f;
  CHECK_THROWS_WITH(tube_mesh(o), Contains("blend must be in [0, 1]"));
  o = {};
  o.blend = 0.0f, o.falloff = TubeFalloff::smoothstep;
  CHECK_THROWS_WITH(tube_mesh(o), Contains("(0, 1] for smoothstep"));
}

TEST_CASE("tube_character: a two-joint rig whose weights sum to 1", "[character][tube]") {
  TubeOptions o;
  o.rings = 8, o.segments = 6, o.caps = true, o.blend = 0.5f;
  const Character ch = tube_character(o);
  CHECK(ch.skeleton.names == std::vector<std::string>{"root", "bone1"});
  CHECK(ch.skeleton.parents == std::vector<std::int32_t>{-1, 0});
  CHECK(ch.skeleton.rest_local[1].translation == Vec3{0.0f, 1.0f, 0.0f});
  REQUIRE(ch.mesh.num_vertices() == 50);
  const TubeMesh m = tube_mesh(o);
  for (std::int64_t v = 0; v < 50; ++v) {
    float sum = 0, w1 = 0;
    for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k) {
      CHECK(ch.mesh.weights.weight[k] > 0.0f);
      sum += ch.mesh.weights.weight[k];
      if (ch.mesh.weights.joint[k] == 1) w1 = ch.mesh.weights.weight[k];
    }
    CHECK(sum == Approx(1.0f));
    CHECK(w1 == m.bone1_weight[std::size_t(v)]);
  }
}

TEST_CASE("tube data: arm poses with LBS corrections, arms with two-bone weights", "[character][tube]") {
  const auto a = tube_samples(models::Task::displacement, 3, 5), b = tube_samples(models::Task::displacement, 3, 5);
  const TubeMesh arm = tube_mesh(tube_arm_options());
  REQUIRE(a.size() == 3);
  for (std::size_t k = 0; k < a.size(); ++k) {
    CHECK(a[k].features.rows() == arm.num_vertices());
    CHECK(a[k].features.cols() == kTubeFeatures);
    CHECK(a[k].features.to_vector() == b[k].features.to_vector());  // deterministic per seed
    CHECK(a[k].target.to_vector() == b[k].target.to_vector());
    double upper = 0, elbow = 0;
    for (std::int64_t i = 0; i < arm.num_vertices(); ++i) {
      const float w = arm.bone1_weight[std::size_t(i)];
      const double len = std::hypot(a[k].target.at(i, 0), a[k].target.at(i, 1), a[k].target.at(i, 2));
      if (w == 0.0f) upper = std::max(upper, len);  // on bone 0 alone LBS is the reference
      if (w > 0.2f && w < 0.8f) elbow = std::max(elbow, len);
      // the unit normals of the posed mesh
      const double n = std::hypot(a[k].features.at(i, 3), a[k].features.at(i, 4), a[k].features.at(i, 5));
      CHECK(n == Approx(1.0).margin(1e-5));
    }
    CHECK(upper < 1e-6);  // only the rounding of (x - elbow) + elbow
    CHECK(elbow > 1e-3);
  }
  CHECK(tube_samples(models::Task::displacement, 1, 6)[0].target.to_vector() != a[0].target.to_vector());
  const auto w = tube_samples(models::Task::weights, 4, 5);
  for (const auto& s : w) {
    REQUIRE(s.target.cols() == kTubeBones);
    for (std::int64_t i = 0; i < s.target.rows(); ++i) CHECK(s.target.at(i, 0) + s.target.at(i, 1) == Approx(1.0f));
    CHECK(s.features.rows() == s.graph->num_nodes);
  }
  CHECK(tube_bone_names().size() == std::size_t(kTubeBones));
}
