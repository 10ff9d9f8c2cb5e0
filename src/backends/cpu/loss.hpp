#pragma once
// Losses, reduced to a scalar in double precision.
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// mean over all entries of (pred - target)^2
double mse_forward(const Tensor& pred, const Tensor& target);
// d_pred += scale * 2 (pred - target) / numel
void mse_backward(const Tensor& pred, const Tensor& target, float scale, const Tensor& d_pred);

// KL(target || pred) = Σ_rows Σ_c t log(t / p) / rows, with 0 log 0 = 0 and p
// clamped to >= eps so a zero prediction under positive target stays finite.
double kl_div_forward(const Tensor& pred, const Tensor& target, float eps);
// d_pred += scale * (-t / max(p, eps)) / rows
void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, float scale, const Tensor& d_pred);

}  // namespace gatcore::cpu
