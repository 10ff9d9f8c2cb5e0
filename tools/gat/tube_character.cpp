#include "tube_character.hpp"

#include <cmath>

#include "gatcore/character/rig/vec3.hpp"

namespace demo {

namespace {
using gatcore::character::add;
using gatcore::character::distance;
using gatcore::character::sub;
constexpr float kPi = 3.14159265358979f;

// Rotation R = Rx(bend) * Ry(twist) applied to v.
Vec3 rotate(const Vec3& v, float bend, float twist) {
  const float ct = std::cos(twist), st = std::sin(twist);
  const Vec3 a{ct * v[0] + st * v[2], v[1], -st * v[0] + ct * v[2]};
  const float cb = std::cos(bend), sb = std::sin(bend);
  return {a[0], cb * a[1] - sb * a[2], sb * a[1] + cb * a[2]};
}
}  // namespace

TubeCharacter make_tube(int rings, int segments, float radius) {
  TubeCharacter c;
  c.joints = {Vec3{0.f, 0.f, 0.f}, Vec3{0.f, 1.f, 0.f}, Vec3{0.f, 2.f, 0.f}};
  for (int r = 0; r < rings; ++r) {
    const float y = 2.0f * static_cast<float>(r) / static_cast<float>(rings - 1);
    // Smoothstep blend over [0.7, 1.3] around the elbow.
    float t = std::fmin(1.f, std::fmax(0.f, (y - 0.7f) / 0.6f));
    const float w = t * t * (3.f - 2.f * t);
    for (int s = 0; s < segments; ++s) {
      const float a = 2.f * kPi * static_cast<float>(s) / static_cast<float>(segments);
      // Elliptic cross-section: a twist of the forearm is visible in the geometry.
      c.rest.push_back({radius * std::cos(a), y, 0.6f * radius * std::sin(a)});
      c.elbow_weight.push_back(w);
    }
  }
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const std::int32_t a = r * segments + s, b = r * segments + (s + 1) % segments;
      const std::int32_t d = a + segments, e = b + segments;
      c.triangles.insert(c.triangles.end(), {a, b, e, a, e, d});
    }
  return c;
}

std::vector<Vec3> skin_lbs(const TubeCharacter& c, const Pose& p) {
  std::vector<Vec3> out(c.rest.size());
  for (std::size_t i = 0; i < c.rest.size(); ++i) {
    const float w = c.elbow_weight[i];
    const Vec3 moved = add(rotate(sub(c.rest[i], c.elbow), p.bend, p.twist), c.elbow);
    for (int k = 0; k < 3; ++k) out[i][k] = (1.f - w) * c.rest[i][k] + w * moved[k];
  }
  return out;
}

std::vector<Vec3> skin_target(const TubeCharacter& c, const Pose& p) {
  std::vector<Vec3> out(c.rest.size());
  for (std::size_t i = 0; i < c.rest.size(); ++i) {
    const float w = c.elbow_weight[i];
    out[i] = add(rotate(sub(c.rest[i], c.elbow), w * p.bend, w * p.twist), c.elbow);
  }
  return out;
}

gatcore::Tensor node_features(const TubeCharacter& c, const std::vector<Vec3>& x, const Pose& p) {
  const std::int64_t n = c.num_vertices();
  std::vector<Vec3> nrm(n, Vec3{0.f, 0.f, 0.f});
  for (std::size_t t = 0; t + 2 < c.triangles.size(); t += 3) {
    const Vec3 &a = x[c.triangles[t]], &b = x[c.triangles[t + 1]], &d = x[c.triangles[t + 2]];
    const Vec3 u = sub(b, a), v = sub(d, a);
    const Vec3 cr{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    for (int k = 0; k < 3; ++k)
      for (int m = 0; m < 3; ++m) nrm[c.triangles[t + k]][m] += cr[m];  // |cross| = 2 * area
  }
  const Vec3 wrist = add(rotate(sub(c.joints[2], c.elbow), p.bend, p.twist), c.elbow);
  const std::array<Vec3, 3> joints{c.joints[0], c.joints[1], wrist};
  gatcore::Tensor f = gatcore::Tensor::empty(n, 9);
  for (std::int64_t i = 0; i < n; ++i) {
    const float len = std::sqrt(nrm[i][0] * nrm[i][0] + nrm[i][1] * nrm[i][1] + nrm[i][2] * nrm[i][2]);
    for (int k = 0; k < 3; ++k) {
      f.at(i, k) = x[i][k];
      f.at(i, 3 + k) = len > 0.f ? nrm[i][k] / len : 0.f;
      f.at(i, 6 + k) = distance(x[i], joints[k]);
    }
  }
  return f;
}

}  // namespace demo
