#pragma once
// DenseNet concatenation without copies: one [n, total] buffer whose column
// slices are handed to the blocks as their output tensors; block m reads the
// prefix slice [0, offset_m). The gradient split is the same slicing of the
// gradient buffer. The copy kernels below are for the few places where a
// tensor that already exists elsewhere must enter the buffer (e.g. the input
// features) and for its gradient.
#include <cstdint>
#include <vector>

#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

struct DenseLayout {
  std::vector<std::int64_t> offsets;  // [slots + 1] column offsets
  std::int64_t width() const { return offsets.empty() ? 0 : offsets.back(); }
  std::int64_t slots() const { return static_cast<std::int64_t>(offsets.size()) - 1; }
};
DenseLayout dense_layout(const std::vector<std::int64_t>& widths);

// View of slot s of a buffer laid out by `layout`.
Tensor dense_slot(const Tensor& buffer, const DenseLayout& layout, std::int64_t slot);
// View of slots [0, s): the input of the block that writes slot s.
Tensor dense_prefix(const Tensor& buffer, const DenseLayout& layout, std::int64_t slot);

// dst[:, c0 : c0+src.cols) = src   (row-parallel, vectorised copy)
void concat_copy_forward(const Tensor& src, const Tensor& dst, std::int64_t c0);
// d_src += d_dst[:, c0 : c0+d_src.cols)
void concat_copy_backward(const Tensor& d_dst, std::int64_t c0, const Tensor& d_src);
// out = [a0 | a1 | ...]  (a general concat into a fresh tensor's slices)
void concat_columns(const std::vector<Tensor>& parts, const Tensor& out);

}  // namespace gatcore::cpu
