#include "gatcore/character/deform/deform.hpp"

#include <algorithm>
#include <cmath>

#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

void check_skinning(const Mesh& mesh, std::span<const Mat4> skinning) {
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(mesh.weights.num_vertices() == n, "skinning: weights for ", mesh.weights.num_vertices(),
                " vertices, mesh has ", n);
  const auto J = static_cast<std::int32_t>(skinning.size());
  for (std::int32_t j : mesh.weights.joint)
    GATCORE_CHECK(j >= 0 && j < J, "skinning: a vertex is weighted to joint ", j, " but ", J, " matrices were given");
}

// Dual quaternion of the rigid part of an affine matrix.
struct DualQuat {
  float r[4];  // x, y, z, w
  float d[4];
};

DualQuat to_dual_quat(const Mat4& m) {
  Transform t = to_transform(m);
  const Quat& q = t.rotation;
  const float tx = t.translation[0], ty = t.translation[1], tz = t.translation[2];
  DualQuat dq;
  std::copy(q.begin(), q.end(), dq.r);
  // d = 0.5 * (t, 0) * q
  dq.d[0] = 0.5f * (tx * q[3] + ty * q[2] - tz * q[1]);
  dq.d[1] = 0.5f * (-tx * q[2] + ty * q[3] + tz * q[0]);
  dq.d[2] = 0.5f * (tx * q[1] - ty * q[0] + tz * q[3]);
  dq.d[3] = -0.5f * (tx * q[0] + ty * q[1] + tz * q[2]);
  return dq;
}

}  // namespace

namespace {

// Vertex v's blended 3x4 skinning matrix sum_k w_k M_k, column-major
// (columns 0..2: linear part, column 3: translation; rows 0..2).
void blend_matrix(const SkinWeights& W, std::span<const Mat4> skinning, std::int64_t v, float m[12]) {
  std::fill(m, m + 12, 0.0f);
  for (std::int64_t k = W.ptr[v]; k < W.ptr[v + 1]; ++k) {
    const Mat4& s = skinning[W.joint[k]];
    const float w = W.weight[k];
    for (int c = 0; c < 12; ++c) m[c] += w * s[(c / 3) * 4 + c % 3];
  }
}

}  // namespace

std::vector<float> linear_blend_skinning(const Mesh& mesh, std::span<const Mat4> skinning) {
  std::vector<float> out(static_cast<std::size_t>(3 * mesh.num_vertices()));
  linear_blend_skinning(mesh, skinning, out);
  return out;
}

void linear_blend_skinning(const Mesh& mesh, std::span<const Mat4> skinning, std::span<float> out) {
  check_skinning(mesh, skinning);
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(static_cast<std::int64_t>(out.size()) == 3 * n, "linear_blend_skinning: output of ", out.size(),
                " floats for ", n, " vertices");
  const float* P = mesh.positions.data();
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float m[12];
    blend_matrix(mesh.weights, skinning, v, m);
    const float x = P[3 * v], y = P[3 * v + 1], z = P[3 * v + 2];
    for (int r = 0; r < 3; ++r) out[3 * v + r] = m[r] * x + m[3 + r] * y + m[6 + r] * z + m[9 + r];
  }
}

std::vector<float> skin_vectors(const Mesh& mesh, std::span<const Mat4> skinning, std::span<const float> vectors) {
  std::vector<float> out(static_cast<std::size_t>(3 * mesh.num_vertices()));
  skin_vectors(mesh, skinning, vectors, out);
  return out;
}

void skin_vectors(const Mesh& mesh, std::span<const Mat4> skinning, std::span<const float> vectors,
                  std::span<float> out) {
  check_skinning(mesh, skinning);
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(static_cast<std::int64_t>(vectors.size()) == 3 * n && out.size() == vectors.size(), "skin_vectors: ",
                vectors.size() / 3, " vectors and ", out.size() / 3, " outputs for ", n, " vertices");
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float m[12];
    blend_matrix(mesh.weights, skinning, v, m);  // the translation column is not used
    const float x = vectors[3 * v], y = vectors[3 * v + 1], z = vectors[3 * v + 2];
    for (int r = 0; r < 3; ++r) out[3 * v + r] = m[r] * x + m[3 + r] * y + m[6 + r] * z;
  }
}

std::vector<float> dual_quaternion_skinning(const Mesh& mesh, std::span<const Mat4> skinning) {
  check_skinning(mesh, skinning);
  std::vector<DualQuat> dq(skinning.size());
  for (std::size_t j = 0; j < skinning.size(); ++j) dq[j] = to_dual_quat(skinning[j]);
  const std::int64_t n = mesh.num_vertices();
  std::vector<float> out(static_cast<std::size_t>(3 * n));
  const auto& W = mesh.weights;
  const float* P = mesh.positions.data();
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    // Pivot: the strongest influence; others are flipped into its hemisphere.
    std::int64_t pivot = W.ptr[v];
    for (std::int64_t k = W.ptr[v]; k < W.ptr[v + 1]; ++k)
      if (W.weight[k] > W.weight[pivot]) pivot = k;
    const DualQuat& q0 = dq[W.joint[pivot]];
    float r[4] = {}, d[4] = {};
    for (std::int64_t k = W.ptr[v]; k < W.ptr[v + 1]; ++k) {
      const DualQuat& q = dq[W.joint[k]];
      const float dot = q.r[0] * q0.r[0] + q.r[1] * q0.r[1] + q.r[2] * q0.r[2] + q.r[3] * q0.r[3];
      const float w = dot < 0.0f ? -W.weight[k] : W.weight[k];
      for (int c = 0; c < 4; ++c) {
        r[c] += w * q.r[c];
        d[c] += w * q.d[c];
      }
    }
    const float len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    for (int c = 0; c < 4; ++c) {
      r[c] /= len;
      d[c] /= len;
    }
    // Translation t = 2 (r.w d.v - d.w r.v + r.v x d.v).
    const float t[3] = {2.0f * (r[3] * d[0] - d[3] * r[0] + r[1] * d[2] - r[2] * d[1]),
                        2.0f * (r[3] * d[1] - d[3] * r[1] + r[2] * d[0] - r[0] * d[2]),
                        2.0f * (r[3] * d[2] - d[3] * r[2] + r[0] * d[1] - r[1] * d[0])};
    const Vec3 p = quat_rotate({r[0], r[1], r[2], r[3]}, {P[3 * v], P[3 * v + 1], P[3 * v + 2]});
    for (int c = 0; c < 3; ++c) out[3 * v + c] = p[c] + t[c];
  }
  return out;
}

std::vector<float> vertex_normals(std::span<const float> positions, std::span<const std::int32_t> triangles) {
  std::vector<float> out(positions.size());
  std::vector<double> acc(positions.size());
  vertex_normals(positions, triangles, out, acc);
  return out;
}

void vertex_normals(std::span<const float> positions, std::span<const std::int32_t> triangles, std::span<float> out,
                    std::span<double> acc) {
  GATCORE_CHECK(positions.size() % 3 == 0 && triangles.size() % 3 == 0,
                "vertex_normals: positions and triangles must be multiples of 3");
  GATCORE_CHECK(out.size() == positions.size() && acc.size() == positions.size(), "vertex_normals: output (",
                out.size(), ") and scratch (", acc.size(), ") must match the positions (", positions.size(), ")");
  const std::int64_t n = static_cast<std::int64_t>(positions.size() / 3);
  std::fill(acc.begin(), acc.end(), 0.0);
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const std::int32_t a = triangles[t], b = triangles[t + 1], c = triangles[t + 2];
    GATCORE_CHECK(a >= 0 && b >= 0 && c >= 0 && a < n && b < n && c < n, "vertex_normals: triangle ", t / 3,
                  " references a missing vertex");
    double e1[3], e2[3];
    for (int k = 0; k < 3; ++k) {
      e1[k] = positions[3 * b + k] - positions[3 * a + k];
      e2[k] = positions[3 * c + k] - positions[3 * a + k];
    }
    // |e1 x e2| = 2 * area: summing the unnormalised cross products weights by area.
    const double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
                 nz = e1[0] * e2[1] - e1[1] * e2[0];
    for (std::int32_t v : {a, b, c}) {
      acc[3 * v] += nx;
      acc[3 * v + 1] += ny;
      acc[3 * v + 2] += nz;
    }
  }
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    const double l = std::sqrt(acc[3 * v] * acc[3 * v] + acc[3 * v + 1] * acc[3 * v + 1] + acc[3 * v + 2] * acc[3 * v + 2]);
    for (int c = 0; c < 3; ++c) out[3 * v + c] = l > 0.0 ? static_cast<float>(acc[3 * v + c] / l) : 0.0f;
  }
}

std::vector<float> laplacian_smooth(const DeltaMush& dm, std::span<const float> x0, int iterations, float step) {
  std::vector<float> out(x0.size()), scratch(x0.size());
  laplacian_smooth(dm, x0, iterations, step, out, scratch);
  return out;
}

void laplacian_smooth(const DeltaMush& dm, std::span<const float> x0, int iterations, float step, std::span<float> out,
                      std::span<float> scratch) {
  const std::int64_t n = static_cast<std::int64_t>(dm.adj_ptr.size()) - 1;
  GATCORE_CHECK(static_cast<std::int64_t>(x0.size()) == 3 * n, "laplacian_smooth: ", x0.size() / 3,
                " vertices, the adjacency has ", n);
  GATCORE_CHECK(out.size() == x0.size() && scratch.size() == x0.size(), "laplacian_smooth: output (", out.size(),
                ") and scratch (", scratch.size(), ") must match the input (", x0.size(), ")");
  GATCORE_CHECK(iterations >= 0, "laplacian_smooth: iterations must be >= 0, got ", iterations);
  if (out.data() != x0.data()) std::copy(x0.begin(), x0.end(), out.begin());
  // Ping-pong between out and scratch; the result is copied back if it ends in scratch.
  float* a = out.data();
  float* b = scratch.data();
  for (int it = 0; it < iterations; ++it) {
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
    for (std::int64_t v = 0; v < n; ++v) {
      const std::int64_t k0 = dm.adj_ptr[v], k1 = dm.adj_ptr[v + 1];
      if (k0 == k1) {
        for (int c = 0; c < 3; ++c) b[3 * v + c] = a[3 * v + c];
        continue;
      }
      float m[3] = {};
      for (std::int64_t k = k0; k < k1; ++k)
        for (int c = 0; c < 3; ++c) m[c] += a[3 * dm.adj[k] + c];
      const float inv = 1.0f / static_cast<float>(k1 - k0);
      for (int c = 0; c < 3; ++c) b[3 * v + c] = a[3 * v + c] + step * (m[c] * inv - a[3 * v + c]);
    }
    std::swap(a, b);
  }
  if (a != out.data()) std::copy(a, a + out.size(), out.begin());
}

namespace {

std::vector<float> smooth(const DeltaMush& dm, std::span<const float> x0) {
  return laplacian_smooth(dm, x0, dm.params.iterations, dm.params.step);
}

// Orthonormal frame (tangent, bitangent, normal) of vertex v on a smoothed
// mesh; false when it is degenerate (then the world axes are used).
bool frame(const DeltaMush& dm, const std::vector<float>& x, const std::vector<float>& nrm, std::int64_t v,
           float f[3][3]) {
  const float* nv = &nrm[3 * v];
  if (dm.adj_ptr[v] == dm.adj_ptr[v + 1] || (nv[0] == 0.0f && nv[1] == 0.0f && nv[2] == 0.0f)) return false;
  const std::int32_t u = dm.adj[dm.adj_ptr[v]];
  float t[3];
  for (int c = 0; c < 3; ++c) t[c] = x[3 * u + c] - x[3 * v + c];
  const float dn = t[0] * nv[0] + t[1] * nv[1] + t[2] * nv[2];
  for (int c = 0; c < 3; ++c) t[c] -= dn * nv[c];
  const float l = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
  if (!(l > 1e-20f)) return false;
  for (int c = 0; c < 3; ++c) t[c] /= l;
  const float b[3] = {nv[1] * t[2] - nv[2] * t[1], nv[2] * t[0] - nv[0] * t[2], nv[0] * t[1] - nv[1] * t[0]};
  for (int c = 0; c < 3; ++c) {
    f[0][c] = t[c];
    f[1][c] = b[c];
    f[2][c] = nv[c];
  }
  return true;
}

}  // namespace

DeltaMush delta_mush_bind(const Mesh& mesh, const DeltaMushParams& params) {
  GATCORE_CHECK(params.iterations >= 0, "delta mush: iterations must be >= 0, got ", params.iterations);
  GATCORE_CHECK(params.step > 0.0f && params.step <= 1.0f, "delta mush: step must be in (0, 1], got ", params.step);
  DeltaMush dm;
  dm.params = params;
  dm.triangles = mesh.triangles;
  const std::int64_t n = mesh.num_vertices();
  std::vector<std::vector<std::int32_t>> nb(static_cast<std::size_t>(n));
  for (std::size_t t = 0; t + 2 < mesh.triangles.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      const std::int32_t a = mesh.triangles[t + e], b = mesh.triangles[t + (e + 1) % 3];
      nb[a].push_back(b);
      nb[b].push_back(a);
    }
  dm.adj_ptr.assign(1, 0);
  for (auto& l : nb) {
    std::sort(l.begin(), l.end());
    l.erase(std::unique(l.begin(), l.end()), l.end());
    dm.adj.insert(dm.adj.end(), l.begin(), l.end());
    dm.adj_ptr.push_back(static_cast<std::int64_t>(dm.adj.size()));
  }
  const std::vector<float> s = smooth(dm, mesh.positions);
  const std::vector<float> sn = vertex_normals(s, mesh.triangles);
  dm.deltas.resize(static_cast<std::size_t>(3 * n));
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float d[3], f[3][3];
    for (int c = 0; c < 3; ++c) d[c] = mesh.positions[3 * v + c] - s[3 * v + c];
    if (frame(dm, s, sn, v, f)) {
      for (int a = 0; a < 3; ++a) dm.deltas[3 * v + a] = f[a][0] * d[0] + f[a][1] * d[1] + f[a][2] * d[2];
    } else {
      for (int c = 0; c < 3; ++c) dm.deltas[3 * v + c] = d[c];
    }
  }
  return dm;
}

std::vector<float> delta_mush_apply(const DeltaMush& dm, std::span<const float> posed) {
  const std::int64_t n = static_cast<std::int64_t>(dm.adj_ptr.size()) - 1;
  GATCORE_CHECK(static_cast<std::int64_t>(posed.size()) == 3 * n, "delta mush: ", posed.size() / 3,
                " posed vertices, bound to ", n);
  const std::vector<float> s = smooth(dm, posed);
  const std::vector<float> sn = vertex_normals(s, dm.triangles);
  std::vector<float> out(static_cast<std::size_t>(3 * n));
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t v = 0; v < n; ++v) {
    float f[3][3];
    const float* d = &dm.deltas[3 * v];
    if (frame(dm, s, sn, v, f)) {
      for (int c = 0; c < 3; ++c) out[3 * v + c] = s[3 * v + c] + f[0][c] * d[0] + f[1][c] * d[1] + f[2][c] * d[2];
    } else {
      for (int c = 0; c < 3; ++c) out[3 * v + c] = s[3 * v + c] + d[c];
    }
  }
  return out;
}

}  // namespace gatcore::character
