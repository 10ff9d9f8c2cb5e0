#pragma once
// Procedural characters for the model / trainer tests: a w×h grid mesh bent
// into a wave, 9 features per vertex (position, normal-ish, distance to 3
// "joints") and targets that are known smooth functions of the features:
// displacements [n, 3] or skin weights [n, B] (softmax of −distance to B bones).
#include <cmath>
#include <string>
#include <vector>

#include "gatcore/models/sample.hpp"
#include "mesh_fixtures.hpp"

namespace fixtures {

inline gatcore::models::Sample wave_sample(int w, int h, float phase, bool weights = false, int bones = 5,
                                           const std::string& name = "wave") {
  using gatcore::Tensor;
  gatcore::models::Sample s;
  s.name = name;
  s.graph = gatcore::share(grid_graph(w, h));
  const std::int64_t n = std::int64_t(w) * h;
  s.features = Tensor::empty(n, 9);
  s.target = Tensor::empty(n, weights ? bones : 3);
  const float joints[3][3] = {{0.f, 0.f, 0.f}, {0.5f, 0.5f, 0.2f}, {1.f, 1.f, 0.f}};
  for (std::int64_t i = 0; i < n; ++i) {
    const float x = float(i % w) / float(w - 1), y = float(i / w) / float(h - 1);
    const float z = 0.3f * std::sin(3.f * x + phase) * std::cos(2.f * y);
    const float f[9] = {x, y, z, -std::cos(3.f * x + phase), std::sin(2.f * y), 1.f, 0.f, 0.f, 0.f};
    for (int k = 0; k < 6; ++k) s.features.at(i, k) = f[k];
    for (int j = 0; j < 3; ++j)
      s.features.at(i, 6 + j) = std::sqrt((x - joints[j][0]) * (x - joints[j][0]) + (y - joints[j][1]) * (y - joints[j][1]) +
                                          (z - joints[j][2]) * (z - joints[j][2]));
    if (!weights) {
      s.target.at(i, 0) = 0.1f * std::sin(2.f * x + phase) * y;
      s.target.at(i, 1) = 0.1f * z * z + 0.05f * x;
      s.target.at(i, 2) = 0.08f * std::cos(3.f * y) * (1.f + phase);
    } else {
      double sum = 0;
      std::vector<double> e(static_cast<std::size_t>(bones));
      for (int b = 0; b < bones; ++b) {
        const float bx = float(b) / float(bones - 1);
        e[b] = std::exp(-12.0 * ((x - bx) * (x - bx) + 0.3 * (y - 0.5) * (y - 0.5)));
        sum += e[b];
      }
      for (int b = 0; b < bones; ++b) s.target.at(i, b) = float(e[b] / sum);
    }
  }
  return s;
}

}  // namespace fixtures
