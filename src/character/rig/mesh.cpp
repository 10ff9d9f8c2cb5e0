#include "gatcore/character/rig/mesh.hpp"

#include <cmath>
#include <numeric>

#include "gatcore/error.hpp"

namespace gatcore::character {

std::int64_t SkinWeights::max_influences() const {
  std::int64_t m = 0;
  for (std::int64_t v = 0; v < num_vertices(); ++v) m = std::max(m, ptr[v + 1] - ptr[v]);
  return m;
}

std::vector<float> SkinWeights::dense(std::int32_t num_joints) const {
  std::vector<float> d(static_cast<std::size_t>(num_vertices()) * num_joints, 0.0f);
  for (std::int64_t v = 0; v < num_vertices(); ++v)
    for (std::int64_t k = ptr[v]; k < ptr[v + 1]; ++k) d[v * num_joints + joint[k]] += weight[k];
  return d;
}

void Mesh::validate(std::int32_t num_joints, const char* what) const {
  GATCORE_CHECK(positions.size() % 3 == 0, what, ": positions size ", positions.size(), " is not a multiple of 3");
  GATCORE_CHECK(triangles.size() % 3 == 0, what, ": triangles size ", triangles.size(), " is not a multiple of 3");
  const std::int64_t n = num_vertices();
  for (std::size_t i = 0; i < positions.size(); ++i)
    GATCORE_CHECK(std::isfinite(positions[i]), what, ": vertex ", i / 3, " has a non-finite coordinate");
  for (std::size_t i = 0; i < triangles.size(); ++i)
    GATCORE_CHECK(triangles[i] >= 0 && triangles[i] < n, what, ": triangle ", i / 3, " references vertex ",
                  triangles[i], " of ", n);
  GATCORE_CHECK(weights.num_vertices() == n, what, ": skin weights for ", weights.num_vertices(), " vertices, mesh has ",
                n);
  GATCORE_CHECK(weights.joint.size() == weights.weight.size() &&
                    static_cast<std::int64_t>(weights.joint.size()) == weights.ptr.back(),
                what, ": inconsistent skin weight arrays");
  for (std::int64_t v = 0; v < n; ++v) {
    GATCORE_CHECK(weights.ptr[v + 1] > weights.ptr[v], what, ": vertex ", v, " has no skin weight");
    double sum = 0.0;
    for (std::int64_t k = weights.ptr[v]; k < weights.ptr[v + 1]; ++k) {
      GATCORE_CHECK(weights.joint[k] >= 0 && weights.joint[k] < num_joints, what, ": vertex ", v,
                    " is weighted to joint ", weights.joint[k], " of ", num_joints);
      GATCORE_CHECK(std::isfinite(weights.weight[k]) && weights.weight[k] > 0.0f, what, ": vertex ", v,
                    " has weight ", weights.weight[k]);
      sum += weights.weight[k];
    }
    GATCORE_CHECK(std::abs(sum - 1.0) < 1e-4, what, ": weights of vertex ", v, " sum to ", sum);
  }
}

Components connected_components(const Mesh& mesh) {
  const std::int64_t n = mesh.num_vertices();
  std::vector<std::int32_t> parent(static_cast<std::size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const std::int32_t a = find(mesh.triangles[t + e]), b = find(mesh.triangles[t + (e + 1) % 3]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  Components c;
  c.label.assign(static_cast<std::size_t>(n), -1);
  std::vector<std::int32_t> root_label(static_cast<std::size_t>(n), -1);
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int32_t r = find(static_cast<std::int32_t>(v));
    if (root_label[r] < 0) root_label[r] = c.count++;
    c.label[v] = root_label[r];
  }
  return c;
}

}  // namespace gatcore::character
