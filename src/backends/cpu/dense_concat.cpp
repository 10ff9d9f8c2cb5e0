// DenseNet buffer layout and the copy kernels into / out of it.
#include "src/backends/cpu/dense_concat.hpp"

#include <cstring>

#include "src/backends/cpu/nn_detail.hpp"

namespace gatcore::cpu {

using detail::check_arg;
using detail::for_each_row;

DenseLayout dense_layout(const std::vector<std::int64_t>& widths) {
  DenseLayout l;
  l.offsets.reserve(widths.size() + 1);
  l.offsets.push_back(0);
  for (std::size_t s = 0; s < widths.size(); ++s) {
    GATCORE_CHECK(widths[s] >= 0, "dense_layout: widths[", s, "]: must be >= 0, got ", widths[s]);
    l.offsets.push_back(l.offsets.back() + widths[s]);
  }
  return l;
}

namespace {
void check_buffer(const Tensor& buffer, const DenseLayout& layout, std::int64_t slot, std::int64_t max_slot,
                  const char* fn) {
  check_cpu_f32(buffer, fn);
  GATCORE_CHECK(layout.slots() >= 0, fn, ": layout: no offsets");
  GATCORE_CHECK(buffer.cols() == layout.width(), fn, ": buffer: expected ", layout.width(),
                " columns (the layout's width), got shape ", buffer.shape_str());
  GATCORE_CHECK(0 <= slot && slot <= max_slot, fn, ": slot ", slot, " out of range [0, ", max_slot, "] for a layout of ",
                layout.slots(), " slots");
}
}  // namespace

Tensor dense_slot(const Tensor& buffer, const DenseLayout& layout, std::int64_t slot) {
  check_buffer(buffer, layout, slot, layout.slots() - 1, "dense_slot");
  return buffer.cols_slice(layout.offsets[slot], layout.offsets[slot + 1]);
}

Tensor dense_prefix(const Tensor& buffer, const DenseLayout& layout, std::int64_t slot) {
  check_buffer(buffer, layout, slot, layout.slots(), "dense_prefix");
  return buffer.cols_slice(0, layout.offsets[slot]);
}

void concat_copy_forward(const Tensor& src, const Tensor& dst, std::int64_t c0) {
  check_cpu_f32(src, "concat_copy_forward: src");
  check_cpu_f32(dst, "concat_copy_forward: dst");
  GATCORE_CHECK(dst.rows() == src.rows() && c0 >= 0 && c0 + src.cols() <= dst.cols(),
                "concat_copy_forward: dst: columns [", c0, ", ", c0 + src.cols(), ") of a tensor of shape ",
                dst.shape_str(), " cannot hold src of shape ", src.shape_str());
  const std::int64_t n = src.cols();
  if (n == 0) return;
  if (src.data() == dst.data() + c0 && src.ld() == dst.ld()) return;  // already in place
  for_each_row(src.rows(), n, [&](std::int64_t r) {
    std::memmove(dst.row(r) + c0, src.row(r), static_cast<std::size_t>(n) * sizeof(float));
  });
}

void concat_copy_backward(const Tensor& d_dst, std::int64_t c0, const Tensor& d_src) {
  check_cpu_f32(d_dst, "concat_copy_backward: d_dst");
  if (!d_src.defined()) return;
  check_cpu_f32(d_src, "concat_copy_backward: d_src");
  GATCORE_CHECK(d_dst.rows() == d_src.rows() && c0 >= 0 && c0 + d_src.cols() <= d_dst.cols(),
                "concat_copy_backward: d_src: shape ", d_src.shape_str(), " does not match columns [", c0, ", ",
                c0 + d_src.cols(), ") of d_dst of shape ", d_dst.shape_str());
  const std::int64_t n = d_src.cols();
  for_each_row(d_src.rows(), n, [&](std::int64_t r) {
    const float* g = d_dst.row(r) + c0;
    float* o = d_src.row(r);
#pragma omp simd
    for (std::int64_t c = 0; c < n; ++c) o[c] += g[c];
  });
}

void concat_columns(const std::vector<Tensor>& parts, const Tensor& out) {
  check_cpu_f32(out, "concat_columns: out");
  std::int64_t total = 0;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const std::string what = ::gatcore::detail::cat("concat_columns: parts[", k, "]");
    check_cpu_f32(parts[k], what.c_str());
    GATCORE_CHECK(parts[k].rows() == out.rows(), what, ": expected ", out.rows(), " rows (those of out), got shape ",
                  parts[k].shape_str());
    total += parts[k].cols();
  }
  GATCORE_CHECK(total == out.cols(), "concat_columns: out: expected ", total, " columns (the parts' total), got shape ",
                out.shape_str());
  std::int64_t c0 = 0;
  for (const Tensor& p : parts) {
    concat_copy_forward(p, out, c0);
    c0 += p.cols();
  }
}

}  // namespace gatcore::cpu
