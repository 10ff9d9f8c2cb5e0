#include "gatcore/character/data/dataset.hpp"

#include <algorithm>
#include <memory>
#include <cmath>
#include <numeric>
#include <random>

#include <tbb/parallel_pipeline.h>

#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

Character to_world(const Character& ch, const Mat4& bind_to_world) {
  Character w = ch;
  for (std::int64_t v = 0; v < w.mesh.num_vertices(); ++v) {
    const Vec3 p = transform_point(bind_to_world, {ch.mesh.positions[3 * v], ch.mesh.positions[3 * v + 1],
                                                   ch.mesh.positions[3 * v + 2]});
    for (int c = 0; c < 3; ++c) w.mesh.positions[3 * v + c] = p[c];
  }
  const Mat4 inv = inverse(bind_to_world);
  for (auto& ibm : w.skeleton.inverse_bind) ibm = mul(ibm, inv);
  return w;
}

PreparedCharacter prepare_character(const Character& ch, const DeltaMushParams& params,
                                    std::span<const int> distortion_scales) {
  const NormalisationStats n0 = compute_normalisation(ch);
  PreparedCharacter pc;
  pc.character = to_world(ch, n0.bind_to_world);
  pc.norm = compute_normalisation(pc.character);
  pc.norm.bind_to_world = mat4_identity();  // already world (the rest-pose matrix is ~identity now)
  pc.delta_mush = delta_mush_bind(pc.character.mesh, params);
  pc.mesh_graph = graph_from_triangles(pc.character.mesh.num_vertices(), pc.character.mesh.triangles);
  pc.rest = bind_pose(pc.character.skeleton);
  set_distortion_scales(pc, distortion_scales);
  return pc;
}

void set_distortion_scales(PreparedCharacter& pc, std::span<const int> scales) {
  pc.rest_details = laplacian_details(pc.delta_mush, pc.character.mesh.positions, scales);  // checks the scales
  pc.distortion_scales.assign(scales.begin(), scales.end());
}

DetailHalves detail_halves(const PreparedCharacter& pc, std::span<const Mat4> skinning,
                           std::span<const float> lbs_root, const Mat4& to_root) {
  DetailHalves h;
  h.posed = laplacian_details(pc.delta_mush, lbs_root, pc.distortion_scales);
  for (const std::vector<float>& rest : pc.rest_details) {
    // World -> root frame, normalised: the root motion is rigid and the
    // normalisation a uniform scale, so vectors turn by to_root's rotation
    // and scale by norm.scale.
    std::vector<float> r = skin_vectors(pc.character.mesh, skinning, rest);
    for (std::size_t v = 0; v < r.size() / 3; ++v) {
      const float* a = &r[3 * v];
      const float x = a[0], y = a[1], z = a[2];
      for (int c = 0; c < 3; ++c)
        r[3 * v + c] = (to_root[c] * x + to_root[4 + c] * y + to_root[8 + c] * z) * pc.norm.scale;
    }
    h.rest.push_back(std::move(r));
  }
  return h;
}

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

std::int32_t root_motion_joint(const PreparedCharacter& pc) {
  const Skeleton& sk = pc.character.skeleton;
  std::int32_t j = pc.norm.origin_joint >= 0 && pc.norm.origin_joint < sk.num_joints() ? pc.norm.origin_joint : 0;
  for (std::int32_t guard = 0; sk.parents[std::size_t(j)] >= 0 && guard < sk.num_joints(); ++guard)
    j = sk.parents[std::size_t(j)];
  return j;
}

Tensor densegats_model_features(const Tensor& bone_features, const DenseGatsSample& s) {
  const std::int64_t m = bone_features.rows(), k = s.distortion.defined() ? s.distortion.cols() : 0;
  if (k == 0) return bone_features;
  GATCORE_CHECK(s.distortion.rows() == m, "densegats_model_features: ", s.distortion.rows(), " distortion rows for ", m,
                " vertices");
  const std::int64_t f = bone_features.cols();
  Tensor out = Tensor::empty(m, f + k);
  for (std::int64_t i = 0; i < m; ++i) {
    for (std::int64_t c = 0; c < f; ++c) out.at(i, c) = bone_features.at(i, c);
    for (std::int64_t c = 0; c < k; ++c) out.at(i, f + c) = s.distortion.at(i, c);
  }
  return out;
}

Vec3 root_offset_to_world(const DenseGatsSample& s, const Vec3& d) {
  const Mat4& m = s.root_motion;
  return {m[0] * d[0] + m[4] * d[1] + m[8] * d[2], m[1] * d[0] + m[5] * d[1] + m[9] * d[2],
          m[2] * d[0] + m[6] * d[1] + m[10] * d[2]};
}

DenseGatsSample make_densegats_sample(const PreparedCharacter& pc, const Pose& pose, std::int64_t first,
                                      std::int64_t count, bool with_target) {
  const Character& ch = pc.character;
  const std::vector<Mat4> g = global_transforms(ch.skeleton, pose);
  std::vector<Mat4> skin(g.size());
  for (std::size_t j = 0; j < g.size(); ++j) skin[j] = mul(g[j], ch.skeleton.inverse_bind[j]);
  const std::vector<float> lbs_world = linear_blend_skinning(ch.mesh, skin);
  const std::vector<float> lbs = apply_normalisation(pc.norm, lbs_world);

  // The root frame: undo the root's motion (rigid; the root's rest placement
  // is where training poses keep it).
  DenseGatsSample s;
  const std::int32_t r = root_motion_joint(pc);
  const std::vector<Mat4> g_rest = global_transforms(ch.skeleton, pc.rest);
  Transform motion = to_transform(mul(g[std::size_t(r)], inverse(g_rest[std::size_t(r)])));
  motion.scale = {1.0f, 1.0f, 1.0f};  // rigid: offsets keep their length
  s.root_motion = to_matrix(motion);
  const Mat4 to_root = inverse(s.root_motion);
  auto in_root = [&](const std::vector<float>& w) {
    std::vector<float> out(w.size());
    for (std::size_t v = 0; v < w.size() / 3; ++v) {
      const Vec3 q = transform_point(to_root, {w[3 * v], w[3 * v + 1], w[3 * v + 2]});
      for (int c = 0; c < 3; ++c) out[3 * v + c] = q[std::size_t(c)];
    }
    return apply_normalisation(pc.norm, out);
  };
  const std::vector<float> lbs_root = in_root(lbs_world);
  const std::vector<float> mush_root =
      with_target ? in_root(delta_mush_apply(pc.delta_mush, lbs_world)) : std::vector<float>{};
  const std::vector<float> normals = vertex_normals(lbs_root, ch.mesh.triangles);
  std::vector<Vec3> joints = joint_positions(g);
  for (Vec3& j : joints) j = apply_normalisation(pc.norm, transform_point(to_root, j));

  s.vertices = vertex_range(ch.mesh.num_vertices(), first, count);
  const std::int64_t m = static_cast<std::int64_t>(s.vertices.size());
  std::vector<float> p(3 * m), n(3 * m);
  if (with_target) s.target = Tensor::empty(m, 3);
  s.lbs = Tensor::empty(m, 3);
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = s.vertices[i];
      p[3 * i + c] = lbs_root[3 * v + c];
      n[3 * i + c] = normals[3 * v + c];
      s.lbs.at(i, c) = lbs[3 * v + c];
      if (with_target) s.target.at(i, c) = mush_root[3 * v + c] - lbs_root[3 * v + c];
    }
  s.features = densegats_features(p, n, joints);
  if (!pc.distortion_scales.empty()) {
    const DetailHalves h = detail_halves(pc, skin, lbs_root, to_root);
    const std::int64_t S = static_cast<std::int64_t>(h.posed.size());
    s.distortion = Tensor::empty(m, 3 * S);
    for (std::int64_t k = 0; k < S; ++k)
      for (std::int64_t i = 0; i < m; ++i)
        for (int c = 0; c < 3; ++c) {
          const std::size_t e = std::size_t(3 * s.vertices[i] + c);
          s.distortion.at(i, 3 * k + c) = h.rest[std::size_t(k)][e] - h.posed[std::size_t(k)][e];
        }
  }
  s.graph = induced_subgraph(pc.mesh_graph, s.vertices);
  return s;
}

NeuroSkinningSample make_neuroskinning_sample(const PreparedCharacter& pc, std::span<const std::int32_t> vertices) {
  const Character& ch = pc.character;
  const std::vector<float> rest = apply_normalisation(pc.norm, ch.mesh.positions);
  const std::vector<float> normals = vertex_normals(rest, ch.mesh.triangles);
  std::vector<Vec3> joints = joint_positions(global_transforms(ch.skeleton, pc.rest));
  for (Vec3& j : joints) j = apply_normalisation(pc.norm, j);
  NeuroSkinningSample s;
  if (vertices.empty()) s.vertices = vertex_range(ch.mesh.num_vertices(), 0, 0);
  else s.vertices.assign(vertices.begin(), vertices.end());
  const std::int64_t m = static_cast<std::int64_t>(s.vertices.size()), J = ch.skeleton.num_joints();
  std::vector<float> p(3 * m), n(3 * m);
  s.weights = Tensor::zeros(m, J);
  for (std::int64_t i = 0; i < m; ++i) {
    const std::int64_t v = s.vertices[i];
    GATCORE_CHECK(v >= 0 && v < ch.mesh.num_vertices(), "neuroskinning sample: vertex ", v, " outside the mesh");
    for (int c = 0; c < 3; ++c) {
      p[3 * i + c] = rest[3 * v + c];
      n[3 * i + c] = normals[3 * v + c];
    }
    for (std::int64_t k = ch.mesh.weights.ptr[v]; k < ch.mesh.weights.ptr[v + 1]; ++k)
      s.weights.at(i, ch.mesh.weights.joint[k]) = ch.mesh.weights.weight[k];
  }
  s.features = neuroskinning_features(p, n, joints, ch.skeleton.parents);
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
                    make_densegats_sample(characters[t.character], t.pose, t.first, t.count));
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
