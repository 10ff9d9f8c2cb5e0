// The ARAP reference deformer (character/arap.hpp): rigid motions reproduced
// exactly, the energy never rising from one iteration to the next, a planar
// strip pulled at its ends stretching uniformly (the analytic solution),
// handle selection by dominant weight, and bad input.
#include <catch2/catch.hpp>

#include <cmath>

#include "gatcore/character/deform/arap.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

float max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  REQUIRE(a.size() == b.size());
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

Character small_humanoid() {
  ProceduralOptions o;
  o.ring_segments = 8;
  o.rings_per_bone = 4;
  o.garments = false;
  return procedural_character(o);
}

Pose bent(const Character& ch) {
  Pose p = bind_pose(ch.skeleton);
  for (std::size_t j = 1; j < p.local.size(); ++j)
    p.local[j].rotation = quat_mul(p.local[j].rotation, quat_from_axis_angle({1.0f, 0.3f, 0.0f}, 0.5f));
  return p;
}

// A w x h planar grid in the xy plane, spacing 1, two triangles per cell.
void grid(int w, int h, std::vector<float>& pos, std::vector<std::int32_t>& tris) {
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) pos.insert(pos.end(), {float(x), float(y), 0.0f});
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const int a = y * w + x, b = a + 1, c = a + w, d = c + 1;
      tris.insert(tris.end(), {a, b, d, a, d, c});
    }
}

}  // namespace

TEST_CASE("arap: a rigid motion of the whole skeleton is reproduced exactly") {
  const Character ch = small_humanoid();
  const ArapBinding b = arap_bind(ch.mesh);
  CHECK(b.num_handles() > 0);
  CHECK(b.num_handles() < b.num_vertices());  // the blend regions are free
  Pose p = bind_pose(ch.skeleton);
  p.local[0].rotation = quat_mul(quat_from_axis_angle({0.2f, 1.0f, 0.1f}, 1.1f), p.local[0].rotation);
  p.local[0].translation[0] += 0.7f;
  p.local[0].translation[2] -= 0.3f;
  const std::vector<float> lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, p));
  std::vector<double> e;
  const std::vector<float> x = arap_apply(b, lbs, &e);
  CHECK(max_abs_diff(x, lbs) < 1e-5f);
  REQUIRE(e.size() == 10);
  for (double v : e) CHECK(v < 1e-9);
  // From a perturbed start, the free vertices go back to the rigid motion.
  std::vector<float> noisy = lbs;
  for (std::int64_t v = 0; v < b.num_vertices(); ++v)
    if (!b.is_handle[v])
      for (int c = 0; c < 3; ++c) noisy[3 * v + c] += 0.01f * std::sin(float(7 * v + 3 * c));
  ArapBinding many = arap_bind(ch.mesh, {200, 0.95f});
  CHECK(max_abs_diff(arap_apply(many, noisy), lbs) < 2e-4f);
}

TEST_CASE("arap: the energy does not rise from one iteration to the next, and ends below LBS's") {
  const Character ch = small_humanoid();
  const ArapBinding b = arap_bind(ch.mesh, {25, 0.95f});
  const std::vector<float> lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, bent(ch)));
  std::vector<double> e;
  const std::vector<float> x = arap_apply(b, lbs, &e);
  const double e0 = arap_energy(b, lbs);
  REQUIRE(e.size() == 25);
  INFO("LBS energy " << e0 << ", after 1: " << e.front() << ", after 25: " << e.back());
  CHECK(e.front() < e0);
  CHECK(e.back() < 0.95 * e0);  // most of LBS's energy is between handles, where ARAP cannot move
  for (std::size_t k = 1; k < e.size(); ++k) {
    INFO("iteration " << k);
    CHECK(e[k] <= e[k - 1] * (1.0 + 1e-6) + 1e-12);
  }
  // Handles stay where LBS put them; free vertices move.
  float moved = 0.0f;
  for (std::int64_t v = 0; v < b.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c) {
      const float d = std::abs(x[3 * v + c] - lbs[3 * v + c]);
      if (b.is_handle[v]) CHECK(d == 0.0f);
      else moved = std::max(moved, d);
    }
  CHECK(moved > 1e-3f);
}

TEST_CASE("arap: a planar strip pulled at both ends stretches uniformly (the analytic solution)") {
  // Rotations stay the identity (the edge covariance of a uniform stretch is
  // symmetric positive definite) and, with the rotations fixed, a linear
  // field solves the cotangent Laplace equation at interior vertices.
  std::vector<float> pos;
  std::vector<std::int32_t> tris;
  const int w = 9, h = 4;
  grid(w, h, pos, tris);
  std::vector<std::uint8_t> handles(pos.size() / 3, 0);
  std::vector<float> start = pos;
  const float stretch = 1.25f;
  for (int y = 0; y < h; ++y) {
    handles[std::size_t(y * w)] = 1;
    handles[std::size_t(y * w + w - 1)] = 1;
    start[3 * std::size_t(y * w + w - 1)] = stretch * float(w - 1);
  }
  const ArapBinding b = arap_bind(pos, tris, handles, {300, 0.95f});
  CHECK(b.num_handles() == 2 * h);
  const std::vector<float> x = arap_apply(b, start);
  for (int y = 0; y < h; ++y)
    for (int i = 0; i < w; ++i) {
      const std::size_t v = std::size_t(y * w + i);
      INFO("vertex " << i << ", " << y);
      CHECK(x[3 * v] == Approx(stretch * float(i)).margin(1e-4));
      CHECK(x[3 * v + 1] == Approx(float(y)).margin(1e-4));
      CHECK(x[3 * v + 2] == Approx(0.0).margin(1e-5));
    }
}

TEST_CASE("arap: handles from the dominant weight, a handle for every component, bad input named") {
  std::vector<float> pos;
  std::vector<std::int32_t> tris;
  grid(3, 3, pos, tris);
  // No handle at all: the (only) component gets its first vertex.
  const ArapBinding b = arap_bind(pos, tris, std::vector<std::uint8_t>(9, 0));
  CHECK(b.num_handles() == 1);
  CHECK(b.is_handle[0] == 1);
  // Translating the handle translates everything.
  std::vector<float> moved = pos;
  for (std::size_t v = 0; v < 9; ++v) moved[3 * v + 2] += 0.5f;
  CHECK(max_abs_diff(arap_apply(b, moved), moved) < 1e-5f);

  const Character ch = small_humanoid();
  const ArapBinding strict = arap_bind(ch.mesh, {10, 1.0f}), loose = arap_bind(ch.mesh, {10, 0.5f});
  CHECK(strict.num_handles() <= arap_bind(ch.mesh).num_handles());
  CHECK(loose.num_handles() > arap_bind(ch.mesh).num_handles());

  CHECK_THROWS_WITH(arap_bind(ch.mesh, {0, 0.95f}), Catch::Contains("iterations must be in [1, 10000], got 0"));
  CHECK_THROWS_WITH(arap_bind(ch.mesh, {10, 1.5f}), Catch::Contains("handle_weight must be in (0, 1], got 1.5"));
  CHECK_THROWS_WITH(arap_apply(b, std::vector<float>(6)), Catch::Contains("2 vertices, bound to 9"));
  std::vector<float> nan = pos;
  nan[4] = std::nanf("");
  CHECK_THROWS_WITH(arap_apply(b, nan), Catch::Contains("non-finite initial position"));
  std::vector<std::int32_t> bad = tris;
  bad[0] = 42;
  CHECK_THROWS_WITH(arap_bind(pos, bad, std::vector<std::uint8_t>(9, 0)), Catch::Contains("triangle vertex 42"));
}
