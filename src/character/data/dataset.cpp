#include "gatcore/character/data/dataset.hpp"

#include <algorithm>
#include <memory>
#include <cmath>
#include <numeric>
#include <random>

#include <tbb/parallel_pipeline.h>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

std::vector<std::int32_t> vertex_range(std::int64_t n, std::int64_t first, std::int64_t count) {
  if (count <= 0 || count >= n) {
    first = 0;
    count = n;
  }
  GATCORE_CHECK(first >= 0 && first + count <= n, "sample: vertices [", first, ", ", first + count,
                ") outside the mesh's ", n);
  std::vector<std::int32_t> v(static_cast<std::size_t>(count));
  std::iota(v.begin(), v.end(), static_cast<std::int32_t>(first));
  return v;
}

}  // namespace

DenseGatsSample make_densegats_sample(const PreparedCharacter& pc, const Pose& pose, std::int64_t first,
                                      std::int64_t count, bool with_target, std::int32_t target_frame) {
  const Character& ch = pc.character;
  const PosedFrame f = pose_frame(pc, pose);
  DenseGatsSample s;
  s.root_motion = f.root_motion;
  const std::vector<float> mush_root =
      !with_target   ? std::vector<float>{}
      : pc.reference ? to_root_frame(pc, f, pc.reference->deform(f.lbs_world, target_frame))
                     : to_root_frame(pc, f, delta_mush_apply(pc.delta_mush, f.lbs_world));
  s.vertices = vertex_range(ch.mesh.num_vertices(), first, count);
  const std::int64_t m = static_cast<std::int64_t>(s.vertices.size());
  if (with_target) s.target = Tensor::empty(m, 3);
  s.lbs = Tensor::empty(m, 3);
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = s.vertices[i];
      s.lbs.at(i, c) = f.lbs[3 * v + c];
      if (with_target) s.target.at(i, c) = mush_root[3 * v + c] - f.lbs_root[3 * v + c];
    }
  s.features = densegats_frame_features(f, s.vertices);
  s.distortion = distortion_frame_features(pc, f, s.vertices);
  s.graph = induced_subgraph(pc.mesh_graph, s.vertices);
  return s;
}

NeuroSkinningSample make_neuroskinning_sample(const PreparedCharacter& pc, std::span<const std::int32_t> vertices) {
  const Character& ch = pc.character;
  NeuroSkinningSample s;
  if (vertices.empty()) s.vertices = vertex_range(ch.mesh.num_vertices(), 0, 0);
  else s.vertices.assign(vertices.begin(), vertices.end());
  s.features = neuroskinning_rest_features(pc, s.vertices);  // checks the vertices
  const std::int64_t m = static_cast<std::int64_t>(s.vertices.size()), J = ch.skeleton.num_joints();
  s.weights = Tensor::zeros(m, J);
  for (std::int64_t i = 0; i < m; ++i) {
    const std::int64_t v = s.vertices[i];
    for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k)
      s.weights.at(i, ch.mesh.weights.joint[k]) = ch.mesh.weights.weight[k];
  }
  s.graph = induced_subgraph(pc.mesh_graph, s.vertices);
  return s;
}

Split split_by_character(std::int32_t n, float validation, float test, std::uint32_t seed) {
  GATCORE_CHECK(n >= 0 && validation >= 0.0f && test >= 0.0f && validation + test < 1.0f,
                "split_by_character: need n >= 0 and validation + test < 1, got n ", n, ", ", validation, ", ", test);
  std::vector<std::int32_t> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::mt19937 rng(seed);
  for (std::int32_t i = n - 1; i > 0; --i) std::swap(order[i], order[rng() % static_cast<std::uint32_t>(i + 1)]);
  auto take = [&](float f) {
    std::int32_t k = static_cast<std::int32_t>(std::lround(f * static_cast<float>(n)));
    if (f > 0.0f && k == 0 && n >= 3) k = 1;
    return k;
  };
  const std::int32_t nv = take(validation), nt = take(test);
  Split s;
  s.validation.assign(order.begin(), order.begin() + nv);
  s.test.assign(order.begin() + nv, order.begin() + nv + nt);
  s.train.assign(order.begin() + nv + nt, order.end());
  for (auto* v : {&s.train, &s.validation, &s.test}) std::sort(v->begin(), v->end());
  return s;
}

void stream_densegats_samples(const std::vector<PreparedCharacter>& characters, const std::vector<SampleTask>& tasks,
                              const std::function<void(DenseGatsSample&&)>& sink, int tokens) {
  GATCORE_CHECK(tokens >= 1, "stream_densegats_samples: tokens must be >= 1, got ", tokens);
  for (const SampleTask& t : tasks)
    GATCORE_CHECK(t.character >= 0 && t.character < static_cast<std::int32_t>(characters.size()),
                  "stream_densegats_samples: task for character ", t.character, " of ", characters.size());
  std::size_t next = 0;
  tbb::parallel_pipeline(
      static_cast<std::size_t>(tokens),
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next == tasks.size()) {
                                              fc.stop();
                                              return 0;
                                            }
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, DenseGatsSample*>(
              tbb::filter_mode::parallel,
              [&](std::size_t i) {
                SerialRegion serial;  // no OpenMP inside TBB tasks
                const SampleTask& t = tasks[i];
                auto s = std::make_unique<DenseGatsSample>(
                    make_densegats_sample(characters[t.character], t.pose, t.first, t.count, true, t.target_frame));
                s->character = t.character;
                s->pose = t.pose_index;
                return s.release();
              }) &
          tbb::make_filter<DenseGatsSample*, void>(tbb::filter_mode::serial_in_order, [&](DenseGatsSample* s) {
            std::unique_ptr<DenseGatsSample> own(s);
            sink(std::move(*own));
          }));
}

}  // namespace gatcore::character
