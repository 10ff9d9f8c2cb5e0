#pragma once
// Dense GEMM on gatcore tensors (strided views allowed) through Eigen::Map:
//   C = alpha * op(A) * op(B) + beta * C,  op(X) = X or X^T.
// Deterministic across thread counts: gatcore threads it itself over fixed
// 512×512 tiles of C (and fixed k-chunks when C is one tile), each a serial
// Eigen call, instead of Eigen's own thread-count-dependent blocking.
// Precision::bf16: both operands rounded to bfloat16 (round to nearest even),
// products accumulated in fp32 (VDPBF16PS on AVX512_BF16 CPUs, a scalar
// emulation elsewhere: the training products, gemm_bf16_train.cpp); the
// same scheme with 1024×1024 tiles, so also deterministic across thread counts.
// C must not overlap A or B (a DenseNet prefix and its next slot may share a
// buffer); beta = 0 ignores C's previous contents (NaN included).
#include "gatcore/precision.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

void gemm(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha = 1.0f,
          float beta = 0.0f, Precision precision = Precision::fp32);

}  // namespace gatcore::cpu
