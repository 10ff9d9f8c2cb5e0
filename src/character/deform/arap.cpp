#include "gatcore/character/deform/arap.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

struct ArapFactor {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
};

std::int64_t ArapBinding::num_handles() const {
  return std::count(is_handle.begin(), is_handle.end(), std::uint8_t(1));
}

namespace {

using V3 = Eigen::Vector3d;

V3 at(std::span<const float> x, std::int64_t v) { return {x[3 * v], x[3 * v + 1], x[3 * v + 2]}; }

void check_params(const ArapParams& p) {
  GATCORE_CHECK(p.iterations >= 1 && p.iterations <= 10000, "arap: iterations must be in [1, 10000], got ",
                p.iterations);
  GATCORE_CHECK(p.handle_weight > 0.0f && p.handle_weight <= 1.0f, "arap: handle_weight must be in (0, 1], got ",
                p.handle_weight);
}

// `priority`: per vertex, which vertex of a handle-less component becomes
// its handle (the largest; ties: the first).
ArapBinding bind_impl(std::span<const float> rest, std::span<const std::int32_t> triangles,
                 std::vector<std::uint8_t> handles, std::span<const float> priority, const ArapParams& params) {
  check_params(params);
  const std::int64_t n = static_cast<std::int64_t>(rest.size() / 3);
  GATCORE_CHECK(rest.size() == std::size_t(3 * n), "arap: ", rest.size(), " rest coordinates is not 3 per vertex");
  GATCORE_CHECK(static_cast<std::int64_t>(handles.size()) == n, "arap: ", handles.size(), " handle flags for ", n,
                " vertices");
  GATCORE_CHECK(triangles.size() % 3 == 0, "arap: ", triangles.size(), " triangle indices is not 3 per triangle");
  for (float c : rest) GATCORE_CHECK(std::isfinite(c), "arap: non-finite rest position");
  for (std::int32_t t : triangles)
    GATCORE_CHECK(t >= 0 && t < n, "arap: triangle vertex ", t, " outside the mesh's ", n, " vertices");

  // Cotangent weights: each triangle adds cot(angle) / 2 to its opposite edge.
  std::vector<std::map<std::int32_t, double>> w(static_cast<std::size_t>(n));
  for (std::size_t t = 0; t < triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t o = triangles[t + k], a = triangles[t + (k + 1) % 3], b = triangles[t + (k + 2) % 3];
      if (a == b) continue;
      const V3 u = at(rest, a) - at(rest, o), v = at(rest, b) - at(rest, o);
      const double cr = u.cross(v).norm();
      const double cot = cr > 1e-12 * (u.squaredNorm() + v.squaredNorm()) ? 0.5 * u.dot(v) / cr : 0.0;
      w[a][b] += cot;
      w[b][a] += cot;
    }
  // Components through edges of positive weight: each needs a handle, else
  // its translation is free and the solve singular.
  std::vector<std::int32_t> parent(static_cast<std::size_t>(n));
  for (std::int64_t v = 0; v < n; ++v) parent[v] = std::int32_t(v);
  const auto find = [&](std::int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::int64_t v = 0; v < n; ++v)
    for (const auto& [j, c] : w[v])
      if (c > 0.0) {
        const std::int32_t a = find(std::int32_t(v)), r = find(j);
        if (a != r) parent[std::max(a, r)] = std::min(a, r);
      }
  std::vector<std::int32_t> best(static_cast<std::size_t>(n), -1);
  std::vector<std::uint8_t> has(static_cast<std::size_t>(n), 0);
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int32_t c = find(std::int32_t(v));
    if (handles[v]) has[c] = 1;
    if (best[c] < 0 || priority[v] > priority[best[c]]) best[c] = std::int32_t(v);
  }
  for (std::int64_t c = 0; c < n; ++c)
    if (best[c] >= 0 && !has[c]) handles[best[c]] = 1;

  ArapBinding b;
  b.params = params;
  b.rest.assign(rest.begin(), rest.end());
  b.is_handle = std::move(handles);
  b.free_index.assign(static_cast<std::size_t>(n), -1);
  std::int32_t nf = 0;
  for (std::int64_t v = 0; v < n; ++v)
    if (!b.is_handle[v]) b.free_index[v] = nf++;
  b.adj_ptr.assign(1, 0);
  std::vector<Eigen::Triplet<double>> trip;
  for (std::int64_t v = 0; v < n; ++v) {
    double diag = 0;
    for (const auto& [j, c] : w[v]) {
      const double wij = std::max(c, 0.0);
      b.adj.push_back(j);
      b.weight.push_back(wij);
      diag += wij;
      const std::int32_t fj = b.free_index[j];
      if (b.free_index[v] >= 0 && fj >= 0 && wij > 0.0) trip.emplace_back(b.free_index[v], fj, -wij);
    }
    if (b.free_index[v] >= 0) trip.emplace_back(b.free_index[v], b.free_index[v], diag);
    b.adj_ptr.push_back(static_cast<std::int64_t>(b.adj.size()));
  }
  auto f = std::make_shared<ArapFactor>();
  if (nf > 0) {
    Eigen::SparseMatrix<double> L(nf, nf);
    L.setFromTriplets(trip.begin(), trip.end());
    f->ldlt.compute(L);
    GATCORE_CHECK(f->ldlt.info() == Eigen::Success, "arap: the free vertices' Laplacian could not be factorised (",
                  nf, " free vertices)");
  }
  b.factor = std::move(f);
  return b;
}

// Local step: the rotation minimising vertex i's term for positions x.
void rotations(const ArapBinding& b, std::span<const float> x, std::vector<Eigen::Matrix3d>& R) {
  const std::int64_t n = b.num_vertices();
  R.resize(static_cast<std::size_t>(n));
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
  for (std::int64_t i = 0; i < n; ++i) {
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    const V3 pi = at(b.rest, i), xi = at(x, i);
    for (std::int64_t k = b.adj_ptr[i]; k < b.adj_ptr[i + 1]; ++k) {
      const std::int32_t j = b.adj[k];
      S += b.weight[k] * (pi - at(b.rest, j)) * (xi - at(x, j)).transpose();
    }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d U = svd.matrixU();
    Eigen::Matrix3d r = svd.matrixV() * U.transpose();
    if (r.determinant() < 0) {  // a reflection: flip the axis of the smallest singular value
      U.col(2) *= -1.0;
      r = svd.matrixV() * U.transpose();
    }
    R[std::size_t(i)] = r;
  }
}

double energy(const ArapBinding& b, std::span<const float> x, const std::vector<Eigen::Matrix3d>& R) {
  const std::int64_t n = b.num_vertices();
  double e = 0;
#pragma omp parallel for schedule(static) reduction(+ : e) if (!SerialRegion::active())
  for (std::int64_t i = 0; i < n; ++i) {
    const V3 pi = at(b.rest, i), xi = at(x, i);
    for (std::int64_t k = b.adj_ptr[i]; k < b.adj_ptr[i + 1]; ++k) {
      const std::int32_t j = b.adj[k];
      e += b.weight[k] * ((xi - at(x, j)) - R[std::size_t(i)] * (pi - at(b.rest, j))).squaredNorm();
    }
  }
  return e;
}

}  // namespace

ArapBinding arap_bind(const Mesh& mesh, const ArapParams& params) {
  const std::int64_t n = mesh.num_vertices();
  GATCORE_CHECK(mesh.weights.num_vertices() == n, "arap: weights for ", mesh.weights.num_vertices(),
                " vertices, mesh has ", n);
  check_params(params);
  std::vector<float> dominant(static_cast<std::size_t>(n), 0.0f);
  std::vector<std::uint8_t> handles(static_cast<std::size_t>(n), 0);
  for (std::int64_t v = 0; v < n; ++v) {
    for (std::int64_t k = mesh.weights.ptr[v]; k < mesh.weights.ptr[v + 1]; ++k)
      dominant[v] = std::max(dominant[v], mesh.weights.weight[k]);
    handles[v] = dominant[v] >= params.handle_weight;
  }
  return bind_impl(mesh.positions, mesh.triangles, std::move(handles), dominant, params);
}

ArapBinding arap_bind(std::span<const float> rest, std::span<const std::int32_t> triangles,
                      std::vector<std::uint8_t> handles, const ArapParams& params) {
  const std::vector<float> first(rest.size() / 3, 0.0f);  // ties: the component's first vertex
  return bind_impl(rest, triangles, std::move(handles), first, params);
}

double arap_energy(const ArapBinding& b, std::span<const float> x) {
  GATCORE_CHECK(static_cast<std::int64_t>(x.size()) == 3 * b.num_vertices(), "arap: ", x.size() / 3,
                " vertices, bound to ", b.num_vertices());
  std::vector<Eigen::Matrix3d> R;
  rotations(b, x, R);
  return energy(b, x, R);
}

std::vector<float> arap_apply(const ArapBinding& b, std::span<const float> initial, std::vector<double>* energies) {
  const std::int64_t n = b.num_vertices();
  GATCORE_CHECK(static_cast<std::int64_t>(initial.size()) == 3 * n, "arap: ", initial.size() / 3,
                " vertices, bound to ", n);
  for (float c : initial) GATCORE_CHECK(std::isfinite(c), "arap: non-finite initial position");
  std::vector<float> x(initial.begin(), initial.end());
  if (energies) energies->clear();
  std::int64_t nf = 0;
  for (std::int32_t f : b.free_index) nf += f >= 0;
  std::vector<Eigen::Matrix3d> R;
  Eigen::MatrixXd rhs(nf, 3), sol;
  for (int it = 0; it < b.params.iterations; ++it) {
    rotations(b, x, R);
    if (nf == 0) break;
    // Global step: for free i, sum_j w_ij (x_i - x_j) = sum_j w_ij/2 (R_i + R_j)(p_i - p_j),
    // handle neighbours moved to the right-hand side.
#pragma omp parallel for schedule(static) if (!SerialRegion::active())
    for (std::int64_t i = 0; i < n; ++i) {
      const std::int32_t fi = b.free_index[i];
      if (fi < 0) continue;
      V3 r = V3::Zero();
      const V3 pi = at(b.rest, i);
      for (std::int64_t k = b.adj_ptr[i]; k < b.adj_ptr[i + 1]; ++k) {
        const std::int32_t j = b.adj[k];
        r += 0.5 * b.weight[k] * (R[std::size_t(i)] + R[std::size_t(j)]) * (pi - at(b.rest, j));
        if (b.free_index[j] < 0) r += b.weight[k] * at(x, j);
      }
      rhs.row(fi) = r.transpose();
    }
    sol = b.factor->ldlt.solve(rhs);
    for (std::int64_t i = 0; i < n; ++i)
      if (const std::int32_t fi = b.free_index[i]; fi >= 0)
        for (int c = 0; c < 3; ++c) x[3 * i + c] = float(sol(fi, c));
    if (energies) energies->push_back(arap_energy(b, x));
  }
  return x;
}

}  // namespace gatcore::character
