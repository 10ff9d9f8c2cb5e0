#pragma once
// Adam (Kingma & Ba 2015) update with bias correction, one pass per parameter.
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// m = b1 m + (1-b1) g;  v = b2 v + (1-b2) g^2;
// p -= lr * (m / (1-b1^t)) / (sqrt(v / (1-b2^t)) + eps)   (+ weight decay on g)
void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr, float beta1,
                 float beta2, float eps, float weight_decay, long step);

}  // namespace gatcore::cpu
