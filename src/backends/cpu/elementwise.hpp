#pragma once
// Elementwise and reduction kernels (row-parallel over strided tensors).
#include "gatcore/activation.hpp"
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/inference.hpp"

namespace gatcore::cpu {

using gatcore::Activation;  // include/gatcore/activation.hpp

// y = f(x); `slope` is the LeakyReLU negative slope.
void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope = 0.01f);
// d_x += f'(x) ⊙ d_y. tanh uses y; tanhshrink needs x; the ReLU family uses
// x. tanh is a vectorised approximation (max error ~3e-7).
// accumulate = false writes d_x = f'(x) ⊙ d_y instead, ignoring its old
// contents (NaN included): the bits of accumulating onto zeros, without the
// zero fill (a fresh gradient buffer).
void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y, const Tensor& d_x,
                         float slope = 0.01f, bool accumulate = true);

// y = alpha*a + beta*b      (y may alias a or b)
void axpby(float alpha, const Tensor& a, float beta, const Tensor& b, const Tensor& y);
// y += alpha * x
void axpy(float alpha, const Tensor& x, const Tensor& y);
// y = a ⊙ b
void mul(const Tensor& a, const Tensor& b, const Tensor& y);
// d_a += b ⊙ d_y  (and symmetric for b, by the caller)
void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a);
// y[i,:] += bias[0,:]   (bias: [1, C])
void add_row_bias(const Tensor& bias, const Tensor& y);
// d_bias[0,c] += Σ_i d_y[i,c]   (deterministic blocked column sums)
void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias);
// Σ of all entries in double precision.
double sum_all(const Tensor& x);
// y = value  (alias for fill without the version bump semantics of Tensor::fill_)
void fill(const Tensor& y, float value);

}  // namespace gatcore::cpu
