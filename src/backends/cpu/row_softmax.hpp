#pragma once
// Softmax over the columns of each row (the skin-weight classifier output).
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// y[i,:] = softmax(x[i,:]); columns with mask[0,c] == 0 get probability 0
// (mask may be undefined: no mask). A row whose mask is all zero gives 0.
void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y);
// d_x += y ⊙ (d_y − <y, d_y>_row)
void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x);

}  // namespace gatcore::cpu
