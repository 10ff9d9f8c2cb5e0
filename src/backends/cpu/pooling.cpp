// Segment max / broadcast and neighbour mean. Every output element has one
// writer and a fixed summation order, so results do not depend on the
// number of threads.
#include "src/backends/cpu/pooling.hpp"

#include <omp.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "src/backends/cpu/nn_detail.hpp"

namespace gatcore::cpu {

namespace {

using detail::check_arg;
using detail::for_each_row;

// Columns per segment-max task: one cache line / one AVX-512 register.
constexpr std::int64_t kColBlock = 16;

void check_i32(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* what) {
  GATCORE_CHECK(t.defined(), what, ": tensor is undefined");
  GATCORE_CHECK(t.device() == Device::cpu, what, ": tensor lives on ", device_name(t.device()),
                ", this kernel runs on the CPU");
  GATCORE_CHECK(t.dtype() == DType::i32, what, ": expected int32");
  check_shape(t, rows, cols, what);
}

// seg_ptr: S+1 non-decreasing offsets from 0 to n.
void check_segments(std::span<const std::int64_t> seg, std::int64_t n, const char* fn) {
  GATCORE_CHECK(!seg.empty(), fn, ": seg_ptr: empty (needs S + 1 offsets)");
  GATCORE_CHECK(seg.front() == 0 && seg.back() == n, fn, ": seg_ptr: must start at 0 and end at the row count ", n,
                ", got [", seg.front(), ", ..., ", seg.back(), "]");
  for (std::size_t s = 1; s < seg.size(); ++s)
    GATCORE_CHECK(seg[s - 1] <= seg[s], fn, ": seg_ptr: decreases at ", s, " (", seg[s - 1], " > ", seg[s], ")");
}

// Structural checks of a neighbour graph (index ranges are CsrGraph::validate's job).
void check_graph(const CsrGraph& g, bool need_transpose, const char* fn) {
  const std::int64_t n = g.num_nodes;
  GATCORE_CHECK(n >= 0 && static_cast<std::int64_t>(g.indptr.size()) == n + 1 && g.indptr[0] == 0 &&
                    g.indptr[n] == g.num_edges(),
                fn, ": nbr: malformed CSR (num_nodes ", n, ", indptr size ", g.indptr.size(), ", ", g.num_edges(),
                " edges)");
  if (need_transpose)
    GATCORE_CHECK(static_cast<std::int64_t>(g.out_ptr.size()) == n + 1 &&
                      static_cast<std::int64_t>(g.out_dst.size()) == g.num_edges() && g.out_ptr[0] == 0 &&
                      g.out_ptr[n] == g.num_edges(),
                  fn, ": nbr: transpose arrays missing or malformed (out_ptr size ", g.out_ptr.size(),
                  ", out_dst size ", g.out_dst.size(), ", ", g.num_edges(), " edges)");
}

// Rows [begin, end) of the calling thread (edge-balanced over `ptr`).
template <class F>
void for_rows_balanced(std::span<const std::int64_t> ptr, std::int64_t work, F&& f) {
  const std::int64_t n = static_cast<std::int64_t>(ptr.size()) - 1;
#pragma omp parallel if (detail::parallel_worth(work))
  {
    const int nt = omp_get_num_threads(), t = omp_get_thread_num();
    const RowRange rr = balanced_rows(ptr, t, nt);
    for (std::int64_t i = rr.begin; i < rr.end && i < n; ++i) f(i);
  }
}

}  // namespace

// ---- segment max --------------------------------------------------------------------

void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out,
                         const Tensor& argmax) {
  check_cpu_f32(x, "segment_max_forward: x");
  const std::int64_t n = x.rows(), C = x.cols();
  check_segments(seg_ptr, n, "segment_max_forward");
  GATCORE_CHECK(n <= std::numeric_limits<std::int32_t>::max(), "segment_max_forward: x: ", n,
                " rows do not fit the int32 argmax");
  const std::int64_t S = static_cast<std::int64_t>(seg_ptr.size()) - 1;
  check_arg(out, S, C, "segment_max_forward: out");
  check_i32(argmax, S, C, "segment_max_forward: argmax");
  const std::int64_t nb = (C + kColBlock - 1) / kColBlock;
  const float* xp = x.data();
  const std::int64_t xld = x.ld();
  float* op = out.data();
  std::int32_t* ap = argmax.data_i32();
  const std::int64_t old = out.ld(), ald = argmax.ld();
#pragma omp parallel for collapse(2) schedule(dynamic, 1) if (S * nb > 1 && detail::parallel_worth(n * C))
  for (std::int64_t s = 0; s < S; ++s)
    for (std::int64_t b = 0; b < nb; ++b) {
      const std::int64_t c0 = b * kColBlock, w = std::min(kColBlock, C - c0);
      const std::int64_t r0 = seg_ptr[s], r1 = seg_ptr[s + 1];
      float best[kColBlock];
      std::int32_t idx[kColBlock];
      if (r0 == r1) {
        for (std::int64_t c = 0; c < w; ++c) {
          best[c] = 0.0f;
          idx[c] = -1;
        }
      } else {
        const float* first = xp + r0 * xld + c0;
        for (std::int64_t c = 0; c < w; ++c) {
          best[c] = first[c];
          idx[c] = static_cast<std::int32_t>(r0);
        }
        for (std::int64_t r = r0 + 1; r < r1; ++r) {
          const float* row = xp + r * xld + c0;
          const std::int32_t ri = static_cast<std::int32_t>(r);
#pragma omp simd
          for (std::int64_t c = 0; c < w; ++c) {
            // Strictly greater: the first maximum wins ties. The first NaN
            // wins over numbers (max propagates NaN, as torch.max does).
            const float v = row[c];
            const bool take = v > best[c] || (v != v && best[c] == best[c]);
            best[c] = take ? v : best[c];
            idx[c] = take ? ri : idx[c];
          }
        }
      }
      for (std::int64_t c = 0; c < w; ++c) {
        op[s * old + c0 + c] = best[c];
        ap[s * ald + c0 + c] = idx[c];
      }
    }
}

void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x) {
  check_cpu_f32(d_out, "segment_max_backward: d_out");
  const std::int64_t S = d_out.rows(), C = d_out.cols();
  check_i32(argmax, S, C, "segment_max_backward: argmax");
  if (!d_x.defined()) return;
  check_cpu_f32(d_x, "segment_max_backward: d_x");
  check_shape(d_x, -1, C, "segment_max_backward: d_x");
  const std::int64_t n = d_x.rows();
  const std::int32_t* ap = argmax.data_i32();
  const std::int64_t ald = argmax.ld();
  for (std::int64_t s = 0; s < S; ++s)
    for (std::int64_t c = 0; c < C; ++c) {
      const std::int32_t i = ap[s * ald + c];
      GATCORE_CHECK(i >= -1 && i < n, "segment_max_backward: argmax: entry [", s, ", ", c, "] = ", i,
                    " is outside [-1, ", n, ") (rows of d_x)");
    }
  const float* g = d_out.data();
  const std::int64_t gld = d_out.ld();
  float* dx = d_x.data();
  const std::int64_t dld = d_x.ld();
  // Each thread owns whole columns, so no two threads write one element
  // whatever argmax holds.
  const std::int64_t nb = (C + kColBlock - 1) / kColBlock;
#pragma omp parallel for schedule(static) if (nb > 1 && detail::parallel_worth(S * C * 8))
  for (std::int64_t b = 0; b < nb; ++b) {
    const std::int64_t c1 = std::min(C, (b + 1) * kColBlock);
    for (std::int64_t s = 0; s < S; ++s)
      for (std::int64_t c = b * kColBlock; c < c1; ++c) {
        const std::int32_t i = ap[s * ald + c];
        if (i >= 0) dx[i * dld + c] += g[s * gld + c];
      }
  }
}

// ---- broadcast ------------------------------------------------------------------------

void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out) {
  check_cpu_f32(x, "broadcast_segments_forward: x");
  check_cpu_f32(out, "broadcast_segments_forward: out");
  check_segments(seg_ptr, out.rows(), "broadcast_segments_forward");
  const std::int64_t S = static_cast<std::int64_t>(seg_ptr.size()) - 1, C = x.cols();
  check_arg(x, S, C, "broadcast_segments_forward: x");
  check_arg(out, -1, C, "broadcast_segments_forward: out");
  const std::int64_t n = out.rows();
#pragma omp parallel if (detail::parallel_worth(n * C))
  {
    const int nt = omp_get_num_threads(), t = omp_get_thread_num();
    const std::int64_t r0 = n * t / nt, r1 = n * (t + 1) / nt;
    // Segment of row r0: the last s with seg_ptr[s] <= r0.
    std::int64_t s = static_cast<std::int64_t>(std::upper_bound(seg_ptr.begin(), seg_ptr.end(), r0) - seg_ptr.begin()) - 1;
    for (std::int64_t r = r0; r < r1; ++r) {
      while (seg_ptr[s + 1] <= r) ++s;
      const float* src = x.row(s);
      float* dst = out.row(r);
#pragma omp simd
      for (std::int64_t c = 0; c < C; ++c) dst[c] = src[c];
    }
  }
}

void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg_ptr, const Tensor& d_x) {
  check_cpu_f32(d_out, "broadcast_segments_backward: d_out");
  check_segments(seg_ptr, d_out.rows(), "broadcast_segments_backward");
  const std::int64_t S = static_cast<std::int64_t>(seg_ptr.size()) - 1, C = d_out.cols();
  if (!d_x.defined()) return;
  check_arg(d_x, S, C, "broadcast_segments_backward: d_x");
  const std::vector<double> sums = detail::segmented_column_sums(seg_ptr, C, [&](std::int64_t r, double* acc) {
    const float* g = d_out.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) acc[c] += static_cast<double>(g[c]);
  });
  for (std::int64_t s = 0; s < S; ++s) {
    float* o = d_x.row(s);
    for (std::int64_t c = 0; c < C; ++c) o[c] += static_cast<float>(sums[s * C + c]);
  }
}

// ---- neighbour mean ------------------------------------------------------------------

void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out) {
  check_graph(nbr, false, "neighbour_mean_forward");
  const std::int64_t N = nbr.num_nodes;
  check_cpu_f32(x, "neighbour_mean_forward: x");
  check_shape(x, N, -1, "neighbour_mean_forward: x");
  const std::int64_t C = x.cols();
  check_arg(out, N, C, "neighbour_mean_forward: out");
  GATCORE_CHECK(!detail::views_overlap(x, out), "neighbour_mean_forward: out ", out.shape_str(), " overlaps x ",
                x.shape_str(), " (the output must not alias the input)");
  const float* xp = x.data();
  const std::int64_t xld = x.ld();
  float* op = out.data();
  const std::int64_t old = out.ld();
  const std::int64_t* ptr = nbr.indptr.data();
  const std::int32_t* idx = nbr.indices.data();
  for_rows_balanced(nbr.indptr, (N + nbr.num_edges()) * C, [&](std::int64_t i) {
    float* o = op + i * old;
    const std::int64_t e0 = ptr[i], e1 = ptr[i + 1];
    if (e0 == e1) {
      std::fill(o, o + C, 0.0f);
      return;
    }
    const float* first = xp + static_cast<std::int64_t>(idx[e0]) * xld;
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) o[c] = first[c];
    for (std::int64_t e = e0 + 1; e < e1; ++e) {
      const float* src = xp + static_cast<std::int64_t>(idx[e]) * xld;
#pragma omp simd
      for (std::int64_t c = 0; c < C; ++c) o[c] += src[c];
    }
    const float inv = 1.0f / static_cast<float>(e1 - e0);
#pragma omp simd
    for (std::int64_t c = 0; c < C; ++c) o[c] *= inv;
  });
}

void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x) {
  check_graph(nbr, true, "neighbour_mean_backward");
  const std::int64_t N = nbr.num_nodes;
  check_cpu_f32(d_out, "neighbour_mean_backward: d_out");
  check_shape(d_out, N, -1, "neighbour_mean_backward: d_out");
  const std::int64_t C = d_out.cols();
  if (!d_x.defined()) return;
  check_arg(d_x, N, C, "neighbour_mean_backward: d_x");
  GATCORE_CHECK(!detail::views_overlap(d_out, d_x), "neighbour_mean_backward: d_x ", d_x.shape_str(),
                " overlaps d_out ", d_out.shape_str(), " (the output must not alias the input)");
  // 1/|N(i)| per destination row, exactly as the forward scales.
  std::vector<float> inv(static_cast<std::size_t>(N));
  for (std::int64_t i = 0; i < N; ++i) {
    const std::int64_t d = nbr.indptr[i + 1] - nbr.indptr[i];
    inv[i] = d > 0 ? 1.0f / static_cast<float>(d) : 0.0f;
  }
  const float* gp = d_out.data();
  const std::int64_t gld = d_out.ld();
  float* dp = d_x.data();
  const std::int64_t dld = d_x.ld();
  const std::int64_t* optr = nbr.out_ptr.data();
  const std::int32_t* odst = nbr.out_dst.data();
  const float* invp = inv.data();
  // Gather over the transpose: row j collects every i that lists j.
  for_rows_balanced(nbr.out_ptr, (N + nbr.num_edges()) * C, [&](std::int64_t j) {
    float* o = dp + j * dld;
    for (std::int64_t p = optr[j]; p < optr[j + 1]; ++p) {
      const std::int64_t i = odst[p];
      const float* g = gp + i * gld;
      const float w = invp[i];
#pragma omp simd
      for (std::int64_t c = 0; c < C; ++c) o[c] += g[c] * w;
    }
  });
}

}  // namespace gatcore::cpu
