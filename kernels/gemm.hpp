#pragma once
// Dense GEMM on gatcore tensors (strided views allowed) through Eigen::Map:
//   C = alpha * op(A) * op(B) + beta * C,  op(X) = X or X^T.
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

void gemm(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha = 1.0f,
          float beta = 0.0f);

}  // namespace gatcore::cpu
