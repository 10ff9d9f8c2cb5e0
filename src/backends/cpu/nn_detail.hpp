#pragma once
// Internal helpers shared by the dense NN kernels (elementwise, batchnorm,
// loss, pooling, softmax). Not part of the installed interface.
//
// Determinism: every reduction here is computed over row blocks of a fixed
// size (kReduceBlockRows, independent of the thread count), one partial per
// block in double, and the partials are combined in block order. Results are
// therefore bitwise identical for any number of OpenMP threads.
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include "gatcore/error.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu::detail {

// Below this many elements a kernel runs on the calling thread only (the
// result does not depend on it; only the overhead does).
inline constexpr std::int64_t kParallelMinElements = 1 << 15;
// Rows per reduction block (fixed: part of the definition of the result).
inline constexpr std::int64_t kReduceBlockRows = 256;

inline bool parallel_worth(std::int64_t elements) { return elements >= kParallelMinElements; }

// f(r) for every row r, rows split statically over the threads.
template <class F>
inline void for_each_row(std::int64_t rows, std::int64_t cols, F&& f) {
#pragma omp parallel for schedule(static) if (parallel_worth(rows * std::max<std::int64_t>(cols, 1)))
  for (std::int64_t r = 0; r < rows; ++r) f(r);
}

// f(base) with base(p) the value an output element adds to: *p when
// `accumulate`, else 0 (a fresh gradient buffer, its contents ignored). The
// kernel writes base(o) + term: the bits of accumulating onto zeros, without
// the zero fill.
template <class F>
inline void with_output_base(bool accumulate, F&& f) {
  if (accumulate)
    f([](const float* p) { return *p; });
  else
    f([](const float*) { return 0.0f; });
}

// Deterministic segmented column reduction.
//   seg: row offsets of S segments (seg[0] = first row, seg[S] = end row).
//   width: accumulators per row block (e.g. C, or 2C for two sums at once).
//   add_row(r, acc): adds row r's contribution into acc[0, width) (double).
// Returns sums [S * width] in double: sums[s*width + k] = Σ_{r in s} contribution_k(r),
// computed as Σ over blocks (in order) of the block partials.
// The same blocks, for a kernel that sums a whole block at a time:
// add_rows(begin, end, acc) adds rows [begin, end) of one block (at most
// kReduceBlockRows, never across a segment) into acc[0, width).
template <class AddRows>
std::vector<double> segmented_column_block_sums(std::span<const std::int64_t> seg, std::int64_t width,
                                                AddRows&& add_rows);

template <class AddRow>
std::vector<double> segmented_column_sums(std::span<const std::int64_t> seg, std::int64_t width, AddRow&& add_row) {
  return segmented_column_block_sums(seg, width, [&](std::int64_t begin, std::int64_t end, double* acc) {
    for (std::int64_t r = begin; r < end; ++r) add_row(r, acc);
  });
}

template <class AddRows>
std::vector<double> segmented_column_block_sums(std::span<const std::int64_t> seg, std::int64_t width,
                                                AddRows&& add_rows) {
  const std::int64_t S = static_cast<std::int64_t>(seg.size()) - 1;
  std::vector<double> out(static_cast<std::size_t>(std::max<std::int64_t>(S, 0) * width), 0.0);
  if (S <= 0 || width <= 0) return out;
  struct Block {
    std::int64_t seg, begin, end;
  };
  std::vector<Block> blocks;
  for (std::int64_t s = 0; s < S; ++s)
    for (std::int64_t b = seg[s]; b < seg[s + 1]; b += kReduceBlockRows)
      blocks.push_back({s, b, std::min(b + kReduceBlockRows, seg[s + 1])});
  const std::int64_t nb = static_cast<std::int64_t>(blocks.size());
  if (nb == 0) return out;
  std::vector<double> partial(static_cast<std::size_t>(nb * width));
  const std::int64_t total_rows = seg[S] - seg[0];
#pragma omp parallel for schedule(static) if (nb > 1 && parallel_worth(total_rows * width))
  for (std::int64_t k = 0; k < nb; ++k) {
    double* acc = partial.data() + k * width;
    for (std::int64_t c = 0; c < width; ++c) acc[c] = 0.0;
    add_rows(blocks[k].begin, blocks[k].end, acc);
  }
  for (std::int64_t k = 0; k < nb; ++k) {
    double* dst = out.data() + blocks[k].seg * width;
    const double* src = partial.data() + k * width;
#pragma omp simd
    for (std::int64_t c = 0; c < width; ++c) dst[c] += src[c];
  }
  return out;
}

// Column sums over all rows [0, rows): a single segment.
template <class AddRow>
std::vector<double> column_sums(std::int64_t rows, std::int64_t width, AddRow&& add_row) {
  const std::int64_t seg[2] = {0, rows};
  return segmented_column_sums(std::span<const std::int64_t>(seg, 2), width, static_cast<AddRow&&>(add_row));
}

// Column sums over all rows [0, rows), a block at a time.
template <class AddRows>
std::vector<double> column_block_sums(std::int64_t rows, std::int64_t width, AddRows&& add_rows) {
  const std::int64_t seg[2] = {0, rows};
  return segmented_column_block_sums(std::span<const std::int64_t>(seg, 2), width, static_cast<AddRows&&>(add_rows));
}

// Shape string "[r, c]" for messages.
inline std::string shape_of(std::int64_t r, std::int64_t c) { return ::gatcore::detail::cat("[", r, ", ", c, "]"); }

// Argument checks: defined CPU float32 tensor of the given shape (-1 = any).
inline void check_arg(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* what) {
  check_cpu_f32(t, what);
  check_shape(t, rows, cols, what);
}
// Same, but an undefined tensor is accepted (optional outputs / gradients).
inline bool check_optional(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* what) {
  if (!t.defined()) return false;
  check_arg(t, rows, cols, what);
  return true;
}

// Do two views share at least one element? (Only views of one storage can.)
inline bool views_overlap(const Tensor& a, const Tensor& b) {
  if (!a.defined() || !b.defined() || a.storage() != b.storage() || a.numel() == 0 || b.numel() == 0) return false;
  const std::int64_t a_end = a.offset() + (a.rows() - 1) * a.ld() + a.cols();
  const std::int64_t b_end = b.offset() + (b.rows() - 1) * b.ld() + b.cols();
  if (a_end <= b.offset() || b_end <= a.offset()) return false;
  if (a.ld() != b.ld() || a.ld() <= 0) return true;  // conservative
  // Same row stride: the views are rectangles of one [*, ld] matrix.
  const std::int64_t ld = a.ld();
  const std::int64_t ar0 = a.offset() / ld, ac0 = a.offset() % ld;
  const std::int64_t br0 = b.offset() / ld, bc0 = b.offset() % ld;
  if (ac0 + a.cols() > ld || bc0 + b.cols() > ld) return true;  // rows wrap: conservative
  const bool rows_meet = ar0 < br0 + b.rows() && br0 < ar0 + a.rows();
  const bool cols_meet = ac0 < bc0 + b.cols() && bc0 < ac0 + a.cols();
  return rows_meet && cols_meet;
}

}  // namespace gatcore::cpu::detail
