#include "gatcore/character/features/frame_features.hpp"

#include <numeric>

#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::vector<std::int32_t> all_vertices(std::int64_t n) {
  std::vector<std::int32_t> v(static_cast<std::size_t>(n));
  std::iota(v.begin(), v.end(), 0);
  return v;
}

std::vector<float> to_root_frame(const PreparedCharacter& pc, const PosedFrame& f, std::span<const float> w) {
  std::vector<float> out(w.size());
  for (std::size_t v = 0; v < w.size() / 3; ++v) {
    const Vec3 q = transform_point(f.to_root, {w[3 * v], w[3 * v + 1], w[3 * v + 2]});
    for (int c = 0; c < 3; ++c) out[3 * v + c] = q[std::size_t(c)];
  }
  return apply_normalisation(pc.normalisation, out);
}

Mat4 rest_root_inverse(const PreparedCharacter& pc) {
  return inverse(global_transforms(pc.character.skeleton, pc.rest)[std::size_t(root_motion_joint(pc))]);
}

PosedFrame pose_frame(const PreparedCharacter& pc, const Pose& pose) {
  PosedFrame f;
  std::vector<double> scratch(pc.character.mesh.positions.size());
  pose_frame(pc, global_transforms(pc.character.skeleton, pose), rest_root_inverse(pc), f, scratch);
  return f;
}

void pose_frame(const PreparedCharacter& pc, std::span<const Mat4> g, const Mat4& inv_rest_root, PosedFrame& f,
                std::span<double> normals_scratch) {
  const Character& ch = pc.character;
  const std::size_t J = ch.skeleton.inverse_bind.size(), n3 = ch.mesh.positions.size();
  GATCORE_CHECK(g.size() == J, ch.name, ": ", g.size(), " joint transforms for ", J, " joints");
  f.skinning.resize(J);
  for (std::size_t j = 0; j < J; ++j) f.skinning[j] = mul(g[j], ch.skeleton.inverse_bind[j]);
  f.lbs_world.resize(n3);
  linear_blend_skinning(ch.mesh, f.skinning, f.lbs_world);
  f.lbs.resize(n3);
  apply_normalisation(pc.normalisation, f.lbs_world, f.lbs);

  // The root frame: undo the root's motion (rigid; the root's rest placement
  // is where training poses keep it).
  Transform motion = to_transform(mul(g[std::size_t(root_motion_joint(pc))], inv_rest_root));
  motion.scale = {1.0f, 1.0f, 1.0f};  // rigid: offsets keep their length
  f.root_motion = to_matrix(motion);
  f.to_root = inverse(f.root_motion);
  // to_root_frame, into f.lbs_root.
  f.lbs_root.resize(n3);
  const std::int64_t n = static_cast<std::int64_t>(n3 / 3);
  const float* w = f.lbs_world.data();
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    const Vec3 q = apply_normalisation(pc.normalisation, transform_point(f.to_root, {w[3 * v], w[3 * v + 1], w[3 * v + 2]}));
    for (int c = 0; c < 3; ++c) f.lbs_root[std::size_t(3 * v + c)] = q[std::size_t(c)];
  }
  f.normals.resize(n3);
  vertex_normals(f.lbs_root, ch.mesh.triangles, f.normals, normals_scratch);
  f.joints.resize(J);
  for (std::size_t j = 0; j < J; ++j)
    f.joints[j] = apply_normalisation(pc.normalisation, transform_point(f.to_root, mat4_translation(g[j])));
}

namespace {

void check_vertices(std::span<const std::int32_t> vertices, std::int64_t n, const char* what) {
  for (const std::int32_t v : vertices)
    GATCORE_CHECK(v >= 0 && v < n, what, ": vertex ", v, " outside the mesh's ", n);
}

}  // namespace

Tensor densegats_frame_features(const PosedFrame& f, std::span<const std::int32_t> vertices) {
  const std::int64_t m = static_cast<std::int64_t>(vertices.size());
  check_vertices(vertices, static_cast<std::int64_t>(f.lbs_root.size() / 3), "densegats_frame_features");
  std::vector<float> p(3 * m), n(3 * m);
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) {
      const std::int64_t v = vertices[i];
      p[3 * i + c] = f.lbs_root[3 * v + c];
      n[3 * i + c] = f.normals[3 * v + c];
    }
  return densegats_features(p, n, f.joints);
}

Tensor distortion_frame_features(const PreparedCharacter& pc, const PosedFrame& f,
                                 std::span<const std::int32_t> vertices) {
  if (pc.distortion_scales.empty()) return {};
  check_vertices(vertices, static_cast<std::int64_t>(f.lbs_root.size() / 3), "distortion_frame_features");
  const DetailHalves h = detail_halves(pc, f.skinning, f.lbs_root, f.to_root);
  const std::int64_t S = static_cast<std::int64_t>(h.posed.size()), m = static_cast<std::int64_t>(vertices.size());
  Tensor d = Tensor::empty(m, 3 * S);
  for (std::int64_t k = 0; k < S; ++k)
    for (std::int64_t i = 0; i < m; ++i)
      for (int c = 0; c < 3; ++c) {
        const std::size_t e = std::size_t(3 * vertices[i] + c);
        d.at(i, 3 * k + c) = h.rest[std::size_t(k)][e] - h.posed[std::size_t(k)][e];
      }
  return d;
}

Tensor densegats_model_features(const Tensor& bone_features, const Tensor& distortion) {
  const std::int64_t m = bone_features.rows(), k = distortion.defined() ? distortion.cols() : 0;
  if (k == 0) return bone_features;
  GATCORE_CHECK(distortion.rows() == m, "densegats_model_features: ", distortion.rows(), " distortion rows for ", m,
                " vertices");
  const std::int64_t f = bone_features.cols();
  Tensor out = Tensor::empty(m, f + k);
  for (std::int64_t i = 0; i < m; ++i) {
    for (std::int64_t c = 0; c < f; ++c) out.at(i, c) = bone_features.at(i, c);
    for (std::int64_t c = 0; c < k; ++c) out.at(i, f + c) = distortion.at(i, c);
  }
  return out;
}

Vec3 root_offset_to_world(const Mat4& m, const Vec3& d) {
  return {m[0] * d[0] + m[4] * d[1] + m[8] * d[2], m[1] * d[0] + m[5] * d[1] + m[9] * d[2],
          m[2] * d[0] + m[6] * d[1] + m[10] * d[2]};
}

Tensor neuroskinning_rest_features(const PreparedCharacter& pc, std::span<const std::int32_t> vertices) {
  const Character& ch = pc.character;
  const std::vector<float> rest = apply_normalisation(pc.normalisation, ch.mesh.positions);
  const std::vector<float> normals = vertex_normals(rest, ch.mesh.triangles);
  std::vector<Vec3> joints = joint_positions(global_transforms(ch.skeleton, pc.rest));
  for (Vec3& j : joints) j = apply_normalisation(pc.normalisation, j);
  const std::int64_t m = static_cast<std::int64_t>(vertices.size());
  std::vector<float> p(3 * m), n(3 * m);
  for (std::int64_t i = 0; i < m; ++i) {
    const std::int64_t v = vertices[i];
    GATCORE_CHECK(v >= 0 && v < ch.mesh.num_vertices(), "neuroskinning sample: vertex ", v, " outside the mesh");
    for (int c = 0; c < 3; ++c) {
      p[3 * i + c] = rest[3 * v + c];
      n[3 * i + c] = normals[3 * v + c];
    }
  }
  return neuroskinning_features(p, n, joints, ch.skeleton.parents);
}

}  // namespace gatcore::character
