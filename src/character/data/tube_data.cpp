#include "gatcore/character/data/tube_data.hpp"

#include <array>
#include <cmath>
#include <string>

#include "gatcore/character/rig/vec3.hpp"
#include "gatcore/nn/init.hpp"

namespace gatcore::character {

namespace {

struct ArmPose {
  float bend = 0.f;   // radians about x at the elbow
  float twist = 0.f;  // radians about the forearm's axis (y)
};

// Rotation R = Rx(bend) * Ry(twist) applied to v.
Vec3 rotate(const Vec3& v, float bend, float twist) {
  const float ct = std::cos(twist), st = std::sin(twist);
  const Vec3 a{ct * v[0] + st * v[2], v[1], -st * v[0] + ct * v[2]};
  const float cb = std::cos(bend), sb = std::sin(bend);
  return {a[0], cb * a[1] - sb * a[2], sb * a[1] + cb * a[2]};
}

Vec3 vertex(const TubeMesh& t, std::size_t i) {
  return {t.positions[3 * i], t.positions[3 * i + 1], t.positions[3 * i + 2]};
}

const Vec3 kElbow{0.f, 1.f, 0.f};
const std::array<Vec3, 3> kJoints{Vec3{0.f, 0.f, 0.f}, Vec3{0.f, 1.f, 0.f}, Vec3{0.f, 2.f, 0.f}};

std::vector<Vec3> rest(const TubeMesh& t) {
  std::vector<Vec3> out(t.bone1_weight.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = vertex(t, i);
  return out;
}

std::vector<Vec3> skin_lbs(const TubeMesh& t, const ArmPose& p) {
  std::vector<Vec3> out(t.bone1_weight.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const float w = t.bone1_weight[i];
    const Vec3 x = vertex(t, i);
    const Vec3 moved = add(rotate(sub(x, kElbow), p.bend, p.twist), kElbow);
    for (int k = 0; k < 3; ++k) out[i][k] = (1.f - w) * x[k] + w * moved[k];
  }
  return out;
}

// Angle-blended skinning: each vertex turns by its weight times the pose.
std::vector<Vec3> skin_reference(const TubeMesh& t, const ArmPose& p) {
  std::vector<Vec3> out(t.bone1_weight.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    const float w = t.bone1_weight[i];
    out[i] = add(rotate(sub(vertex(t, i), kElbow), w * p.bend, w * p.twist), kElbow);
  }
  return out;
}

Tensor arm_features(const TubeMesh& t, const std::vector<Vec3>& x, const ArmPose& p) {
  const std::int64_t n = t.num_vertices();
  std::vector<Vec3> nrm(static_cast<std::size_t>(n), Vec3{0.f, 0.f, 0.f});
  for (std::size_t k = 0; k + 2 < t.triangles.size(); k += 3) {
    const Vec3 &a = x[t.triangles[k]], &b = x[t.triangles[k + 1]], &d = x[t.triangles[k + 2]];
    const Vec3 cr = cross(sub(b, a), sub(d, a));  // |cross| = 2 * area
    for (int c = 0; c < 3; ++c)
      for (int m = 0; m < 3; ++m) nrm[t.triangles[k + c]][m] += cr[m];
  }
  const Vec3 wrist = add(rotate(sub(kJoints[2], kElbow), p.bend, p.twist), kElbow);
  const std::array<Vec3, 3> joints{kJoints[0], kJoints[1], wrist};
  Tensor f = Tensor::empty(n, kTubeFeatures);
  for (std::int64_t i = 0; i < n; ++i) {
    const float len = length(nrm[i]);
    for (int k = 0; k < 3; ++k) {
      f.at(i, k) = x[i][k];
      f.at(i, 3 + k) = len > 0.f ? nrm[i][k] / len : 0.f;
      f.at(i, 6 + k) = distance(x[i], joints[k]);
    }
  }
  return f;
}

}  // namespace

std::vector<std::string> tube_bone_names() { return {"upper_arm", "forearm"}; }

TubeOptions tube_arm_options(int rings, int segments, float radius) {
  TubeOptions o;
  o.rings = rings, o.segments = segments, o.radius = radius;
  o.length = 2.0f, o.depth = 0.6f, o.blend = 0.3f;  // weights blend over y in [0.7, 1.3]
  o.falloff = TubeFalloff::smoothstep;
  o.winding = TubeWinding::inward;
  return o;
}

std::vector<models::Sample> tube_samples(models::Task task, int count, std::uint64_t seed) {
  constexpr float kDeg = 3.14159265358979f / 180.f;
  nn::Rng rng(seed);
  std::vector<models::Sample> out;
  const TubeMesh fixed = tube_mesh(tube_arm_options());
  const GraphPtr fixed_graph = share(graph_from_triangles(fixed.num_vertices(), fixed.triangles));
  for (int k = 0; k < count; ++k) {
    models::Sample s;
    if (task == models::Task::displacement) {
      const ArmPose p{rng.uniform(-110.f, 110.f) * kDeg, rng.uniform(-70.f, 70.f) * kDeg};
      const auto lbs = skin_lbs(fixed, p), ref = skin_reference(fixed, p);
      s.name = "tube pose " + std::to_string(k);
      s.graph = fixed_graph;
      s.features = arm_features(fixed, lbs, p);
      s.target = Tensor::empty(fixed.num_vertices(), 3);
      for (std::int64_t i = 0; i < fixed.num_vertices(); ++i)
        for (int c = 0; c < 3; ++c) s.target.at(i, c) = ref[std::size_t(i)][c] - lbs[std::size_t(i)][c];
    } else {
      const int rings = 16 + int(rng.below(17)), segments = 10 + int(rng.below(11));
      const TubeMesh t = tube_mesh(tube_arm_options(rings, segments, rng.uniform(0.15f, 0.35f)));
      s.name = "tube " + std::to_string(rings) + "x" + std::to_string(segments);
      s.graph = share(graph_from_triangles(t.num_vertices(), t.triangles));
      s.features = arm_features(t, rest(t), ArmPose{});
      s.target = Tensor::empty(t.num_vertices(), kTubeBones);
      for (std::int64_t i = 0; i < t.num_vertices(); ++i) {
        s.target.at(i, 0) = 1.f - t.bone1_weight[std::size_t(i)];
        s.target.at(i, 1) = t.bone1_weight[std::size_t(i)];
      }
      s.bone_mask = Tensor::full(1, kTubeBones, 1.f);
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace gatcore::character
