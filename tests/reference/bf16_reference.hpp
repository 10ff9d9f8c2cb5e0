#pragma once
// Reference side of the bf16 product tests: a tensor's values rounded to
// bf16 (bf16_round, the kernels' rounding) as a double matrix, so that a
// double product of the rounded operands leaves only the fp32 summation error.
#include "src/backends/cpu/gemm_bf16.hpp"
#include "reference/nn_reference.hpp"

namespace gatcore::ref {

inline Mat rounded_bf16(const Tensor& t) {
  Mat m = to_mat(t);
  for (double& v : m.v) v = double(cpu::bf16_round(float(v)));
  return m;
}

}  // namespace gatcore::ref
