#include "tube_data.hpp"

#include <string>

#include "gatcore/nn/init.hpp"
#include "tube_character.hpp"

namespace demo {

std::vector<gatcore::models::Sample> tube_samples(gatcore::models::Task task, int count, std::uint64_t seed) {
  using namespace gatcore;
  constexpr float kDeg = 3.14159265358979f / 180.f;
  nn::Rng rng(seed);
  std::vector<models::Sample> out;
  const TubeCharacter fixed = make_tube();
  const GraphPtr fixed_graph = share(graph_from_triangles(fixed.num_vertices(), fixed.triangles));
  for (int k = 0; k < count; ++k) {
    models::Sample s;
    if (task == models::Task::displacement) {
      const Pose p{rng.uniform(-110.f, 110.f) * kDeg, rng.uniform(-70.f, 70.f) * kDeg};
      const auto lbs = skin_lbs(fixed, p), ref = skin_target(fixed, p);
      s.name = "tube pose " + std::to_string(k);
      s.graph = fixed_graph;
      s.features = node_features(fixed, lbs, p);
      s.target = Tensor::empty(fixed.num_vertices(), 3);
      for (std::int64_t i = 0; i < fixed.num_vertices(); ++i)
        for (int c = 0; c < 3; ++c) s.target.at(i, c) = ref[std::size_t(i)][c] - lbs[std::size_t(i)][c];
    } else {
      const int rings = 16 + int(rng.below(17)), segments = 10 + int(rng.below(11));
      const TubeCharacter t = make_tube(rings, segments, rng.uniform(0.15f, 0.35f));
      s.name = "tube " + std::to_string(rings) + "x" + std::to_string(segments);
      s.graph = share(graph_from_triangles(t.num_vertices(), t.triangles));
      s.features = node_features(t, t.rest, Pose{});
      s.target = Tensor::empty(t.num_vertices(), kTubeBones);
      for (std::int64_t i = 0; i < t.num_vertices(); ++i) {
        s.target.at(i, 0) = 1.f - t.elbow_weight[std::size_t(i)];
        s.target.at(i, 1) = t.elbow_weight[std::size_t(i)];
      }
      s.bone_mask = Tensor::full(1, kTubeBones, 1.f);
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace demo
