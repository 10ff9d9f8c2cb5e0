#pragma once
// Plain double-precision references for the dense NN and pooling kernels, and
// the test helpers around them (random strided tensors, comparisons, thread /
// SIMD-level guards). Used only by the tests: straightforward loops, no
// parallelism, no cleverness.
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "gatcore/activation.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/simd.hpp"

namespace gatcore::ref {

// ---- a dense double matrix --------------------------------------------------------------
struct Mat {
  std::int64_t rows = 0, cols = 0;
  std::vector<double> v;
  Mat() = default;
  Mat(std::int64_t r, std::int64_t c, double fill = 0.0) : rows(r), cols(c), v(static_cast<std::size_t>(r * c), fill) {}
  double& operator()(std::int64_t r, std::int64_t c) { return v[static_cast<std::size_t>(r * cols + c)]; }
  double operator()(std::int64_t r, std::int64_t c) const { return v[static_cast<std::size_t>(r * cols + c)]; }
};

inline Mat to_mat(const Tensor& t) {
  Mat m(t.rows(), t.cols());
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c) m(r, c) = t.at(r, c);
  return m;
}

// ---- GEMM -------------------------------------------------------------------------------
// C = alpha op(A) op(B) + beta C0; `bound` gets Σ|alpha a b| + |beta c| per entry
// (the scale of the rounding error of a float evaluation).
inline Mat gemm(const Mat& A, bool ta, const Mat& B, bool tb, const Mat& C0, double alpha, double beta,
                Mat* bound = nullptr) {
  const std::int64_t m = ta ? A.cols : A.rows, k = ta ? A.rows : A.cols, n = tb ? B.rows : B.cols;
  Mat C(m, n);
  if (bound) *bound = Mat(m, n);
  for (std::int64_t i = 0; i < m; ++i)
    for (std::int64_t j = 0; j < n; ++j) {
      double s = 0, b = 0;
      for (std::int64_t p = 0; p < k; ++p) {
        const double a = ta ? A(p, i) : A(i, p);
        const double bb = tb ? B(j, p) : B(p, j);
        s += a * bb;
        b += std::fabs(a * bb);
      }
      const double c0 = beta == 0.0 ? 0.0 : beta * C0(i, j);
      C(i, j) = alpha * s + c0;
      if (bound) (*bound)(i, j) = std::fabs(alpha) * b + std::fabs(c0);
    }
  return C;
}

// ---- activations --------------------------------------------------------------------------
inline double act(Activation f, double x, double slope) {
  switch (f) {
    case Activation::identity: return x;
    case Activation::tanh: return std::tanh(x);
    case Activation::tanhshrink: return x - std::tanh(x);
    case Activation::leaky_relu: return x > 0 ? x : slope * x;
    case Activation::relu: return x > 0 ? x : 0.0;
  }
  return 0;
}
// f'(x) (ReLU family: derivative 0 / slope at x <= 0, as PyTorch).
inline double act_grad(Activation f, double x, double slope) {
  switch (f) {
    case Activation::identity: return 1.0;
    case Activation::tanh: {
      const double t = std::tanh(x);
      return 1.0 - t * t;
    }
    case Activation::tanhshrink: {
      const double t = std::tanh(x);
      return t * t;
    }
    case Activation::leaky_relu: return x > 0 ? 1.0 : slope;
    case Activation::relu: return x > 0 ? 1.0 : 0.0;
  }
  return 0;
}

// ---- row softmax -----------------------------------------------------------------------------
inline Mat softmax(const Mat& x, const std::vector<double>* mask) {
  Mat y(x.rows, x.cols);
  for (std::int64_t r = 0; r < x.rows; ++r) {
    double m = -std::numeric_limits<double>::infinity();
    for (std::int64_t c = 0; c < x.cols; ++c)
      if (!mask || (*mask)[c] != 0) m = std::max(m, x(r, c));
    if (!(m > -std::numeric_limits<double>::infinity())) continue;  // fully masked: zeros
    double s = 0;
    for (std::int64_t c = 0; c < x.cols; ++c)
      if (!mask || (*mask)[c] != 0) s += std::exp(x(r, c) - m);
    for (std::int64_t c = 0; c < x.cols; ++c)
      y(r, c) = (!mask || (*mask)[c] != 0) ? std::exp(x(r, c) - m) / s : 0.0;
  }
  return y;
}
// d_x = y ⊙ (d_y − <y, d_y>)
inline Mat softmax_backward(const Mat& y, const Mat& dy) {
  Mat dx(y.rows, y.cols);
  for (std::int64_t r = 0; r < y.rows; ++r) {
    double dot = 0;
    for (std::int64_t c = 0; c < y.cols; ++c) dot += y(r, c) * dy(r, c);
    for (std::int64_t c = 0; c < y.cols; ++c) dx(r, c) = y(r, c) * (dy(r, c) - dot);
  }
  return dx;
}

// ---- batch norm ----------------------------------------------------------------------------
struct BnStats {
  std::vector<double> mean, var;  // biased variance
};
inline BnStats column_stats(const Mat& x) {
  BnStats s{std::vector<double>(x.cols, 0.0), std::vector<double>(x.cols, 0.0)};
  for (std::int64_t c = 0; c < x.cols; ++c) {
    double m = 0;
    for (std::int64_t r = 0; r < x.rows; ++r) m += x(r, c);
    m /= static_cast<double>(x.rows);
    double v = 0;
    for (std::int64_t r = 0; r < x.rows; ++r) v += (x(r, c) - m) * (x(r, c) - m);
    s.mean[c] = m;
    s.var[c] = v / static_cast<double>(x.rows);
  }
  return s;
}
// y = (x - mean) / sqrt(var + eps) * gamma + beta, per column.
inline Mat bn_apply(const Mat& x, const std::vector<double>& mean, const std::vector<double>& var, double eps,
                    const std::vector<double>& gamma, const std::vector<double>& beta) {
  Mat y(x.rows, x.cols);
  for (std::int64_t r = 0; r < x.rows; ++r)
    for (std::int64_t c = 0; c < x.cols; ++c)
      y(r, c) = (x(r, c) - mean[c]) / std::sqrt(var[c] + eps) * gamma[c] + beta[c];
  return y;
}
// Gradients of Σ dy ⊙ bn_train(x) w.r.t. x, gamma, beta (batch statistics).
inline void bn_train_backward(const Mat& x, const std::vector<double>& gamma, double eps, const Mat& dy, Mat& dx,
                              std::vector<double>& dgamma, std::vector<double>& dbeta) {
  const BnStats s = column_stats(x);
  const double n = static_cast<double>(x.rows);
  dx = Mat(x.rows, x.cols);
  dgamma.assign(x.cols, 0.0);
  dbeta.assign(x.cols, 0.0);
  for (std::int64_t c = 0; c < x.cols; ++c) {
    const double is = 1.0 / std::sqrt(s.var[c] + eps);
    double sdy = 0, sdyx = 0;
    for (std::int64_t r = 0; r < x.rows; ++r) {
      const double xh = (x(r, c) - s.mean[c]) * is;
      sdy += dy(r, c);
      sdyx += dy(r, c) * xh;
    }
    dbeta[c] = sdy;
    dgamma[c] = sdyx;
    for (std::int64_t r = 0; r < x.rows; ++r) {
      const double xh = (x(r, c) - s.mean[c]) * is;
      dx(r, c) = gamma[c] * is * (dy(r, c) - sdy / n - xh * sdyx / n);
    }
  }
}

// ---- losses ------------------------------------------------------------------------------------
inline double mse(const Mat& p, const Mat& t) {
  double s = 0;
  for (std::size_t i = 0; i < p.v.size(); ++i) s += (p.v[i] - t.v[i]) * (p.v[i] - t.v[i]);
  return s / static_cast<double>(p.v.size());
}
inline double kl(const Mat& p, const Mat& t, double eps) {
  double s = 0;
  for (std::size_t i = 0; i < p.v.size(); ++i)
    if (t.v[i] > 0) s += t.v[i] * std::log(t.v[i] / std::max(p.v[i], eps));
  return s / static_cast<double>(p.rows);
}

// ---- pooling -----------------------------------------------------------------------------------
// Max over the rows of each segment; first maximum wins; empty: 0 and -1.
inline void segment_max(const Mat& x, const std::vector<std::int64_t>& seg, Mat& out, std::vector<std::int32_t>& arg) {
  const std::int64_t S = static_cast<std::int64_t>(seg.size()) - 1;
  out = Mat(S, x.cols);
  arg.assign(static_cast<std::size_t>(S * x.cols), -1);
  for (std::int64_t s = 0; s < S; ++s)
    for (std::int64_t c = 0; c < x.cols; ++c)
      for (std::int64_t r = seg[s]; r < seg[s + 1]; ++r)
        if (r == seg[s] || x(r, c) > out(s, c)) {
          out(s, c) = x(r, c);
          arg[s * x.cols + c] = static_cast<std::int32_t>(r);
        }
}
// out[i] = mean_{j in nbrs[i]} x[j] (0 when empty); d_x[j] = Σ_{i: j in nbrs[i]} d_out[i] / |nbrs[i]|.
inline Mat neighbour_mean(const std::vector<std::vector<std::int32_t>>& nbrs, const Mat& x) {
  Mat out(static_cast<std::int64_t>(nbrs.size()), x.cols);
  for (std::size_t i = 0; i < nbrs.size(); ++i)
    for (std::int32_t j : nbrs[i])
      for (std::int64_t c = 0; c < x.cols; ++c) out(i, c) += x(j, c) / static_cast<double>(nbrs[i].size());
  return out;
}
inline Mat neighbour_mean_backward(const std::vector<std::vector<std::int32_t>>& nbrs, const Mat& d_out) {
  Mat dx(d_out.rows, d_out.cols);
  for (std::size_t i = 0; i < nbrs.size(); ++i)
    for (std::int32_t j : nbrs[i])
      for (std::int64_t c = 0; c < d_out.cols; ++c) dx(j, c) += d_out(i, c) / static_cast<double>(nbrs[i].size());
  return dx;
}

// A CsrGraph built by hand from (sorted, duplicate-free) neighbour lists:
// row i = nbrs[i] = the sources j of the edges j -> i; transpose filled too.
inline CsrGraph csr_from_lists(const std::vector<std::vector<std::int32_t>>& nbrs) {
  CsrGraph g;
  const std::int64_t n = static_cast<std::int64_t>(nbrs.size());
  g.num_nodes = n;
  g.indptr.assign(n + 1, 0);
  for (std::int64_t i = 0; i < n; ++i) {
    std::vector<std::int32_t> row = nbrs[i];
    std::sort(row.begin(), row.end());
    g.indptr[i + 1] = g.indptr[i] + static_cast<std::int64_t>(row.size());
    g.indices.insert(g.indices.end(), row.begin(), row.end());
  }
  const std::int64_t E = g.num_edges();
  g.out_ptr.assign(n + 1, 0);
  for (std::int64_t e = 0; e < E; ++e) ++g.out_ptr[g.indices[e] + 1];
  for (std::int64_t j = 0; j < n; ++j) g.out_ptr[j + 1] += g.out_ptr[j];
  g.out_dst.assign(E, 0);
  g.out_edge.assign(E, 0);
  std::vector<std::int64_t> fill(g.out_ptr.begin(), g.out_ptr.end() - 1);
  for (std::int64_t i = 0; i < n; ++i)  // rows in increasing i: out_dst sorted per j
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      const std::int64_t p = fill[g.indices[e]]++;
      g.out_dst[p] = static_cast<std::int32_t>(i);
      g.out_edge[p] = static_cast<std::int32_t>(e);
    }
  g.segment_ptr = {0, n};
  bool self = n > 0, sym = true;
  for (std::int64_t i = 0; i < n; ++i) {
    self &= std::binary_search(g.indices.begin() + g.indptr[i], g.indices.begin() + g.indptr[i + 1],
                               static_cast<std::int32_t>(i));
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) {
      const std::int32_t j = g.indices[e];
      sym &= std::binary_search(g.indices.begin() + g.indptr[j], g.indices.begin() + g.indptr[j + 1],
                                static_cast<std::int32_t>(i));
    }
  }
  g.self_loops = self;
  g.symmetric = sym;
  return g;
}

}  // namespace gatcore::ref

namespace gatcore::testutil {

using Rng = std::mt19937_64;

// A [rows, cols] tensor filled with uniform values in [lo, hi). strided: a
// column slice of a wider buffer whose other columns hold `kPad` (so tests
// can check that nothing outside the view is written).
inline constexpr float kPad = -777.25f;
inline Tensor make(std::int64_t rows, std::int64_t cols, bool strided) {
  if (!strided) return Tensor::empty(rows, cols);
  const std::int64_t lpad = 3, rpad = 5;
  Tensor parent = Tensor::full(rows, cols + lpad + rpad, kPad);
  return parent.cols_slice(lpad, lpad + cols);
}
inline Tensor random(Rng& rng, std::int64_t rows, std::int64_t cols, bool strided, float lo = -1.0f, float hi = 1.0f) {
  Tensor t = make(rows, cols, strided);
  std::uniform_real_distribution<float> u(lo, hi);
  for (std::int64_t r = 0; r < rows; ++r)
    for (std::int64_t c = 0; c < cols; ++c) t.at(r, c) = u(rng);
  return t;
}
inline Tensor constant(std::int64_t rows, std::int64_t cols, bool strided, float v) {
  Tensor t = make(rows, cols, strided);
  for (std::int64_t r = 0; r < rows; ++r)
    for (std::int64_t c = 0; c < cols; ++c) t.at(r, c) = v;
  return t;
}
// The padding around a strided view (made by `make`) is untouched.
inline bool pad_intact(const Tensor& view) {
  if (view.contiguous() || view.numel() == 0) return true;
  const std::int64_t ld = view.ld(), c0 = view.offset() % ld;
  Tensor parent = Tensor::wrap(view.storage(), DType::f32, view.offset() - c0, view.rows(), ld, ld);
  for (std::int64_t r = 0; r < view.rows(); ++r)
    for (std::int64_t c = 0; c < ld; ++c)
      if ((c < c0 || c >= c0 + view.cols()) && parent.at(r, c) != kPad) return false;
  return true;
}

inline bool bitwise_equal(const Tensor& a, const Tensor& b) {
  if (!a.same_shape(b)) return false;
  for (std::int64_t r = 0; r < a.rows(); ++r)
    if (a.cols() &&
        std::memcmp(a.dtype() == DType::f32 ? static_cast<const void*>(a.row(r)) : a.data_i32() + r * a.ld(),
                    b.dtype() == DType::f32 ? static_cast<const void*>(b.row(r)) : b.data_i32() + r * b.ld(),
                    static_cast<std::size_t>(a.cols()) * 4) != 0)
      return false;
  return true;
}

// |t - ref| <= atol + rtol |ref| everywhere (NaN in t never passes unless ref is NaN).
inline void require_close(const Tensor& t, const ref::Mat& ref, double atol, double rtol, const std::string& what = "") {
  REQUIRE(t.rows() == ref.rows);
  REQUIRE(t.cols() == ref.cols);
  std::int64_t bad = 0, first_r = -1, first_c = -1;
  double worst = 0;
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c) {
      const double got = t.at(r, c), want = ref(r, c);
      const bool both_nan = std::isnan(got) && std::isnan(want);
      const double err = std::fabs(got - want);
      if (!both_nan && !(err <= atol + rtol * std::fabs(want)) && !(got == want)) {
        if (bad++ == 0) first_r = r, first_c = c;
        worst = std::max(worst, std::isnan(err) ? INFINITY : err);
      }
    }
  if (bad) {
    std::ostringstream os;
    os << what << ": " << bad << " of " << t.numel() << " entries off; first at [" << first_r << ", " << first_c
       << "]: got " << t.at(first_r, first_c) << ", want " << ref(first_r, first_c) << "; worst error " << worst;
    FAIL(os.str());
  }
}
// |t - ref| <= rel * bound + atol (bound: error scale per entry, e.g. from ref::gemm).
inline void require_close_bound(const Tensor& t, const ref::Mat& want, const ref::Mat& bound, double rel,
                                double atol, const std::string& what = "") {
  REQUIRE(t.rows() == want.rows);
  REQUIRE(t.cols() == want.cols);
  std::int64_t bad = 0;
  std::ostringstream os;
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c) {
      const double err = std::fabs(t.at(r, c) - want(r, c));
      if (!(err <= rel * bound(r, c) + atol)) {
        if (bad++ == 0)
          os << what << ": first mismatch at [" << r << ", " << c << "]: got " << t.at(r, c) << ", want " << want(r, c)
             << " (bound " << bound(r, c) << ")";
      }
    }
  if (bad) {
    os << "; " << bad << " entries off";
    FAIL(os.str());
  }
}

inline ref::Mat plus(const ref::Mat& a, const ref::Mat& b) {
  ref::Mat c = a;
  for (std::size_t i = 0; i < c.v.size(); ++i) c.v[i] += b.v[i];
  return c;
}

// Sets the OpenMP thread count for a scope.
struct Threads {
  int saved;
  explicit Threads(int n) : saved(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~Threads() { omp_set_num_threads(saved); }
};
// Sets the SIMD level for a scope.
struct Simd {
  cpu::SimdLevel saved;
  explicit Simd(cpu::SimdLevel l) : saved(cpu::simd_level()) { cpu::set_simd_level(l); }
  ~Simd() { cpu::set_simd_level(saved); }
};
// Every level this CPU can run (scalar first).
inline std::vector<cpu::SimdLevel> simd_levels() {
  std::vector<cpu::SimdLevel> v;
  for (int l = 0; l <= static_cast<int>(cpu::detected_simd_level()); ++l) v.push_back(static_cast<cpu::SimdLevel>(l));
  return v;
}

}  // namespace gatcore::testutil
