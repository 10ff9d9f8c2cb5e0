#include "gatcore/character/data/tube.hpp"

#include <algorithm>
#include <cmath>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

float bone1_weight_at(float y, const TubeOptions& o) {
  if (o.falloff == TubeFalloff::smoothstep) {
    const float width = o.blend * o.length, lo = 0.5f * o.length - 0.5f * o.blend * o.length;
    const float t = std::fmin(1.f, std::fmax(0.f, (y - lo) / width));
    return t * t * (3.f - 2.f * t);
  }
  if (o.blend > 0.0f) return std::clamp((y / o.length - 0.5f + 0.5f * o.blend) / o.blend, 0.0f, 1.0f);
  return y / o.length < 0.5f ? 0.0f : 1.0f;
}

}  // namespace

TubeMesh tube_mesh(const TubeOptions& o) {
  GATCORE_CHECK(o.rings >= 2, "tube: rings must be >= 2, got ", o.rings);
  GATCORE_CHECK(o.segments >= 3, "tube: segments must be >= 3, got ", o.segments);
  GATCORE_CHECK(o.length > 0.0f && o.radius > 0.0f && o.depth > 0.0f, "tube: length, radius and depth must be > 0, got ",
                o.length, ", ", o.radius, ", ", o.depth);
  GATCORE_CHECK(o.blend >= 0.0f && o.blend <= 1.0f && (o.falloff == TubeFalloff::linear || o.blend > 0.0f),
                "tube: blend must be in ", o.falloff == TubeFalloff::linear ? "[0, 1]" : "(0, 1] for smoothstep",
                ", got ", o.blend);
  TubeMesh t;
  const int cols = o.segments + (o.seam ? 1 : 0);
  for (int r = 0; r < o.rings; ++r) {
    const float y = o.length * static_cast<float>(r) / static_cast<float>(o.rings - 1);
    const float w = bone1_weight_at(y, o);
    for (int c = 0; c < cols; ++c) {
      const float a = 2.0f * 3.14159265358979f * static_cast<float>(c % o.segments) / static_cast<float>(o.segments);
      t.positions.insert(t.positions.end(), {o.radius * std::cos(a), y, o.depth * o.radius * std::sin(a)});
      t.bone1_weight.push_back(w);
    }
  }
  auto id = [&](int r, int c) { return r * cols + (o.seam ? c : c % o.segments); };
  const bool out = o.winding == TubeWinding::outward;
  for (int r = 0; r + 1 < o.rings; ++r)
    for (int c = 0; c < o.segments; ++c) {
      const int a = id(r, c), b = id(r, c + 1), d = id(r + 1, c), e = id(r + 1, c + 1);
      if (out) t.triangles.insert(t.triangles.end(), {a, d, b, b, d, e});
      else t.triangles.insert(t.triangles.end(), {a, b, e, a, e, d});
    }
  if (o.caps) {
    for (int end = 0; end < 2; ++end) {
      const int r = end ? o.rings - 1 : 0;
      const int centre = static_cast<int>(t.bone1_weight.size());
      t.positions.insert(t.positions.end(), {0.0f, end ? o.length : 0.0f, 0.0f});
      t.bone1_weight.push_back(end ? 1.0f : 0.0f);
      for (int c = 0; c < o.segments; ++c) {
        // The fan faces away from the tube at its end (towards it when inward).
        if ((end != 0) == out) t.triangles.insert(t.triangles.end(), {centre, id(r, c + 1), id(r, c)});
        else t.triangles.insert(t.triangles.end(), {centre, id(r, c), id(r, c + 1)});
      }
    }
  }
  return t;
}

Character tube_character(const TubeOptions& o) {
  const TubeMesh t = tube_mesh(o);
  Character ch;
  ch.name = "tube";
  ch.mesh.positions = t.positions;
  ch.mesh.triangles = t.triangles;
  for (std::size_t v = 0; v < t.bone1_weight.size(); ++v) {
    const float w = t.bone1_weight[v];
    if (1.0f - w > 0.0f) ch.mesh.weights.joint.push_back(0), ch.mesh.weights.weight.push_back(1.0f - w);
    if (w > 0.0f) ch.mesh.weights.joint.push_back(1), ch.mesh.weights.weight.push_back(w);
    ch.mesh.weights.ptr.push_back(static_cast<std::int64_t>(ch.mesh.weights.joint.size()));
    ch.welded_from_file.push_back(static_cast<std::int32_t>(v));
  }
  Skeleton& s = ch.skeleton;
  s.names = {"root", "bone1"};
  s.parents = {-1, 0};
  s.rest_local.resize(2);
  s.rest_local[1].translation = {0.0f, o.length / 2, 0.0f};
  s.root_parent = {mat4_identity(), mat4_identity()};
  s.inverse_bind = {mat4_identity(), inverse(to_matrix(s.rest_local[1]))};
  return ch;
}

}  // namespace gatcore::character
