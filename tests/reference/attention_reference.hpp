#pragma once
// Plain double-precision reference for the graph-attention kernels (tests
// only): straightforward loops over edges, no SIMD, no threads. Backward
// functions return the increments the kernels add to their outputs.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace ref {

struct DMat {
  std::int64_t rows = 0, cols = 0;
  std::vector<double> v;
  DMat() = default;
  DMat(std::int64_t r, std::int64_t c) : rows(r), cols(c), v(static_cast<std::size_t>(r * c), 0.0) {}
  double& operator()(std::int64_t r, std::int64_t c) { return v[static_cast<std::size_t>(r * cols + c)]; }
  double operator()(std::int64_t r, std::int64_t c) const { return v[static_cast<std::size_t>(r * cols + c)]; }
};

inline DMat to_d(const gatcore::Tensor& t) {
  DMat m(t.rows(), t.cols());
  for (std::int64_t r = 0; r < t.rows(); ++r)
    for (std::int64_t c = 0; c < t.cols(); ++c) m(r, c) = t.at(r, c);
  return m;
}

inline gatcore::Tensor to_f(const DMat& m) {
  gatcore::Tensor t = gatcore::Tensor::empty(m.rows, m.cols);
  for (std::int64_t r = 0; r < m.rows; ++r)
    for (std::int64_t c = 0; c < m.cols; ++c) t.at(r, c) = static_cast<float>(m(r, c));
  return t;
}

inline DMat plus(const DMat& a, const DMat& b) {
  DMat c = a;
  for (std::size_t i = 0; i < c.v.size(); ++i) c.v[i] += b.v[i];
  return c;
}

inline double leaky(double x, double slope) { return x > 0 ? x : slope * x; }
inline double leaky_grad(double x, double slope) { return x > 0 ? 1.0 : slope; }

// ---- projection ---------------------------------------------------------------

// el[i,k] = <a_l[k], z_i^k>, er likewise.
inline void projection(const DMat& z, const DMat& al, const DMat& ar, DMat& el, DMat& er) {
  const std::int64_t n = z.rows, H = al.rows, F = al.cols;
  el = DMat(n, H);
  er = DMat(n, H);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t k = 0; k < H; ++k)
      for (std::int64_t f = 0; f < F; ++f) {
        el(i, k) += al(k, f) * z(i, k * F + f);
        er(i, k) += ar(k, f) * z(i, k * F + f);
      }
}

inline void projection_backward(const DMat& z, const DMat& al, const DMat& ar, const DMat& d_el, const DMat& d_er,
                                DMat& d_z, DMat& d_al, DMat& d_ar) {
  const std::int64_t n = z.rows, H = al.rows, F = al.cols;
  d_z = DMat(n, H * F);
  d_al = DMat(H, F);
  d_ar = DMat(H, F);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t k = 0; k < H; ++k)
      for (std::int64_t f = 0; f < F; ++f) {
        d_z(i, k * F + f) += d_el(i, k) * al(k, f) + d_er(i, k) * ar(k, f);
        d_al(k, f) += d_el(i, k) * z(i, k * F + f);
        d_ar(k, f) += d_er(i, k) * z(i, k * F + f);
      }
}

// ---- logits and softmax ---------------------------------------------------------

inline DMat logits_additive(const gatcore::CsrGraph& g, const DMat& el, const DMat& er, double slope) {
  const std::int64_t H = el.cols;
  DMat s(g.num_edges(), H);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k) s(e, k) = leaky(el(i, k) + er(g.indices[e], k), slope);
  return s;
}

inline DMat logits_dot(const gatcore::CsrGraph& g, const DMat& h, std::int64_t H, double scale) {
  const std::int64_t F = h.cols / H;
  DMat s(g.num_edges(), H);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k) {
        double d = 0;
        for (std::int64_t f = 0; f < F; ++f) d += h(i, k * F + f) * h(g.indices[e], k * F + f);
        s(e, k) = scale * d;
      }
  return s;
}

inline DMat softmax(const gatcore::CsrGraph& g, const DMat& s) {
  const std::int64_t H = s.cols;
  DMat a(s.rows, H);
  for (std::int64_t i = 0; i < g.num_nodes; ++i) {
    const std::int64_t b = g.indptr[i], t = g.indptr[i + 1];
    if (b == t) continue;
    for (std::int64_t k = 0; k < H; ++k) {
      double m = -INFINITY, sum = 0;
      for (std::int64_t e = b; e < t; ++e) m = std::max(m, s(e, k));
      for (std::int64_t e = b; e < t; ++e) sum += std::exp(s(e, k) - m);
      for (std::int64_t e = b; e < t; ++e) a(e, k) = std::exp(s(e, k) - m) / sum;
    }
  }
  return a;
}

// ds = alpha (d_alpha - sum_row alpha d_alpha)
inline DMat softmax_backward(const gatcore::CsrGraph& g, const DMat& alpha, const DMat& d_alpha) {
  const std::int64_t H = alpha.cols;
  DMat ds(alpha.rows, H);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t k = 0; k < H; ++k) {
      double dot = 0;
      for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) dot += alpha(e, k) * d_alpha(e, k);
      for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e) ds(e, k) = alpha(e, k) * (d_alpha(e, k) - dot);
    }
  return ds;
}

inline void additive_logit_backward(const gatcore::CsrGraph& g, const DMat& el, const DMat& er, double slope,
                                    const DMat& ds, DMat& d_el, DMat& d_er) {
  const std::int64_t H = el.cols;
  d_el = DMat(el.rows, H);
  d_er = DMat(er.rows, H);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k) {
        const std::int64_t j = g.indices[e];
        const double dx = ds(e, k) * leaky_grad(el(i, k) + er(j, k), slope);
        d_el(i, k) += dx;
        d_er(j, k) += dx;
      }
}

inline DMat dot_logit_backward(const gatcore::CsrGraph& g, const DMat& h, std::int64_t H, double scale,
                               const DMat& ds) {
  const std::int64_t F = h.cols / H;
  DMat d_h(h.rows, h.cols);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k) {
        const std::int64_t j = g.indices[e];
        for (std::int64_t f = 0; f < F; ++f) {
          d_h(i, k * F + f) += scale * ds(e, k) * h(j, k * F + f);
          d_h(j, k * F + f) += scale * ds(e, k) * h(i, k * F + f);
        }
      }
  return d_h;
}

// ---- aggregation ----------------------------------------------------------------

inline DMat aggregate(const gatcore::CsrGraph& g, const DMat& alpha, const DMat& z) {
  const std::int64_t H = alpha.cols, F = z.cols / H;
  DMat out(z.rows, z.cols);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k)
        for (std::int64_t f = 0; f < F; ++f) out(i, k * F + f) += alpha(e, k) * z(g.indices[e], k * F + f);
  return out;
}

inline void aggregate_backward(const gatcore::CsrGraph& g, const DMat& alpha, const DMat& z, const DMat& d_out,
                               DMat& d_alpha, DMat& d_z) {
  const std::int64_t H = alpha.cols, F = z.cols / H;
  d_alpha = DMat(alpha.rows, H);
  d_z = DMat(z.rows, z.cols);
  for (std::int64_t i = 0; i < g.num_nodes; ++i)
    for (std::int64_t e = g.indptr[i]; e < g.indptr[i + 1]; ++e)
      for (std::int64_t k = 0; k < H; ++k) {
        const std::int64_t j = g.indices[e];
        for (std::int64_t f = 0; f < F; ++f) {
          d_alpha(e, k) += d_out(i, k * F + f) * z(j, k * F + f);
          d_z(j, k * F + f) += alpha(e, k) * d_out(i, k * F + f);
        }
      }
}

}  // namespace ref
