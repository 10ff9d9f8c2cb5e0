#include "gatcore/character/features/features.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

float dist_point_segment(const float* p, const Vec3& a, const Vec3& b) {
  float ab[3], ap[3];
  for (int c = 0; c < 3; ++c) {
    ab[c] = b[c] - a[c];
    ap[c] = p[c] - a[c];
  }
  const float l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
  float t = l2 > 0.0f ? (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2 : 0.0f;
  t = std::clamp(t, 0.0f, 1.0f);
  float d2 = 0.0f;
  for (int c = 0; c < 3; ++c) {
    const float e = ap[c] - t * ab[c];
    d2 += e * e;
  }
  return std::sqrt(d2);
}

void check_vertex_arrays(std::span<const float> pos, std::span<const float> nrm, const char* what) {
  GATCORE_CHECK(pos.size() % 3 == 0 && pos.size() == nrm.size(), what, ": positions (", pos.size(),
                ") and normals (", nrm.size(), ") must both hold 3 floats per vertex");
}

}  // namespace

NormalisationStats compute_normalisation(const Character& ch) {
  const Skeleton& s = ch.skeleton;
  GATCORE_CHECK(s.num_joints() > 0, ch.name, ": normalisation needs a skeleton");
  NormalisationStats st;
  st.origin_joint = 0;
  for (const char* key : {"hips", "pelvis", "root"}) {
    bool found = false;
    for (std::int32_t j = 0; j < s.num_joints() && !found; ++j)
      if (lower(s.names[j]).find(key) != std::string::npos) {
        st.origin_joint = j;
        found = true;
      }
    if (found) break;
  }
  st.bind_to_world = skinning_matrices(s, rest_pose(s))[st.origin_joint];
  st.origin = transform_point(st.bind_to_world, mat4_translation(inverse(s.inverse_bind[st.origin_joint])));
  float lo = 0.0f, hi = 0.0f;
  for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
    const Vec3 p = transform_point(st.bind_to_world, {ch.mesh.positions[3 * v], ch.mesh.positions[3 * v + 1],
                                                      ch.mesh.positions[3 * v + 2]});
    if (v == 0) lo = hi = p[1];
    lo = std::min(lo, p[1]);
    hi = std::max(hi, p[1]);
  }
  GATCORE_CHECK(hi > lo, ch.name, ": the rest mesh has zero height");
  st.scale = 1.0f / (hi - lo);
  return st;
}

Vec3 apply_normalisation(const NormalisationStats& s, const Vec3& p) {
  return {(p[0] - s.origin[0]) * s.scale, (p[1] - s.origin[1]) * s.scale, (p[2] - s.origin[2]) * s.scale};
}

std::vector<float> apply_normalisation(const NormalisationStats& s, std::span<const float> positions) {
  std::vector<float> out(positions.size());
  apply_normalisation(s, positions, out);
  return out;
}

void apply_normalisation(const NormalisationStats& s, std::span<const float> positions, std::span<float> out) {
  GATCORE_CHECK(out.size() == positions.size(), "apply_normalisation: output of ", out.size(), " floats for ",
                positions.size());
  const std::int64_t n = static_cast<std::int64_t>(positions.size() / 3);
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    const Vec3 r = apply_normalisation(s, {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]});
    for (int c = 0; c < 3; ++c) out[3 * v + c] = r[c];
  }
}

std::vector<float> normalise_bind_positions(const NormalisationStats& s, std::span<const float> positions) {
  std::vector<float> out(positions.size());
  const std::int64_t n = static_cast<std::int64_t>(positions.size() / 3);
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    const Vec3 r = apply_normalisation(
        s, transform_point(s.bind_to_world, {positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]}));
    for (int c = 0; c < 3; ++c) out[3 * v + c] = r[c];
  }
  return out;
}

std::vector<Vec3> normalised_bind_joints(const NormalisationStats& s, const Skeleton& sk) {
  std::vector<Vec3> out;
  for (const Mat4& ibm : sk.inverse_bind)
    out.push_back(apply_normalisation(s, transform_point(s.bind_to_world, mat4_translation(inverse(ibm)))));
  return out;
}

std::vector<Vec3> joint_positions(std::span<const Mat4> globals) {
  std::vector<Vec3> p;
  p.reserve(globals.size());
  for (const Mat4& m : globals) p.push_back(mat4_translation(m));
  return p;
}

namespace {
// Columns 0-5 of both papers' features: the posed position and normal.
inline void put_position_normal(float* r, std::span<const float> pos, std::span<const float> nrm, std::int64_t v) {
  for (int c = 0; c < 3; ++c) {
    r[c] = pos[3 * v + c];
    r[3 + c] = nrm[3 * v + c];
  }
}
}  // namespace

Tensor densegats_features(std::span<const float> pos, std::span<const float> nrm, std::span<const Vec3> joints) {
  Tensor x = Tensor::empty(static_cast<std::int64_t>(pos.size() / 3), 6 + static_cast<std::int64_t>(joints.size()));
  densegats_features(pos, nrm, joints, x);
  return x;
}

void densegats_features(std::span<const float> pos, std::span<const float> nrm, std::span<const Vec3> joints,
                        const Tensor& x) {
  check_vertex_arrays(pos, nrm, "densegats_features");
  const std::int64_t n = static_cast<std::int64_t>(pos.size() / 3), J = static_cast<std::int64_t>(joints.size());
  check_cpu_f32(x, "densegats_features: out");
  check_shape(x, n, 6 + J, "densegats_features: out");
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float* r = x.row(v);
    put_position_normal(r, pos, nrm, v);
    for (std::int64_t j = 0; j < J; ++j) {
      float d2 = 0.0f;
      for (int c = 0; c < 3; ++c) d2 += (pos[3 * v + c] - joints[j][c]) * (pos[3 * v + c] - joints[j][c]);
      r[6 + j] = std::sqrt(d2);
    }
  }
}

Tensor neuroskinning_features(std::span<const float> pos, std::span<const float> nrm, std::span<const Vec3> joints,
                              std::span<const std::int32_t> parents) {
  check_vertex_arrays(pos, nrm, "neuroskinning_features");
  GATCORE_CHECK(parents.size() == joints.size(), "neuroskinning_features: ", parents.size(), " parents for ",
                joints.size(), " joints");
  const std::int64_t n = static_cast<std::int64_t>(pos.size() / 3), J = static_cast<std::int64_t>(joints.size());
  std::vector<std::vector<std::int32_t>> children(static_cast<std::size_t>(J));
  for (std::int64_t j = 0; j < J; ++j) {
    GATCORE_CHECK(parents[j] >= -1 && parents[j] < J, "neuroskinning_features: joint ", j, " has parent ", parents[j]);
    if (parents[j] >= 0) children[parents[j]].push_back(static_cast<std::int32_t>(j));
  }
  Tensor x = Tensor::empty(n, 6 + J);
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float* r = x.row(v);
    put_position_normal(r, pos, nrm, v);
    for (std::int64_t j = 0; j < J; ++j) {
      float d = dist_point_segment(&pos[3 * v], joints[j], joints[j]);
      for (std::int32_t c : children[j]) d = std::min(d, dist_point_segment(&pos[3 * v], joints[j], joints[c]));
      r[6 + j] = d;
    }
  }
  return x;
}

}  // namespace gatcore::character
