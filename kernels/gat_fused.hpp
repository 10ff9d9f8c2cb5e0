#pragma once
// Fused graph attention: logits + softmax + aggregation in one pass over each
// destination row (online softmax with a running max), storing only the
// normalised attention alpha [E, H] for backward — never an E×H×F tensor.
//   additive: out_i^k = Σ_j softmax_j(LeakyReLU(el[i,k] + er[j,k])) z_j^k
//   dot:      out_i^k = Σ_j softmax_j(scale <z_i^k, z_j^k>) z_j^k
// Results equal edge_softmax_*_forward followed by aggregate_forward.
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                float slope, const Tensor& out, const Tensor& alpha);
void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& out,
                           const Tensor& alpha);

// Backward of the fused forward from the saved alpha: d_alpha is formed per
// row on the fly and never stored. Accumulates into d_z, d_el, d_er.
void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                 float slope, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z,
                                 const Tensor& d_el, const Tensor& d_er);
void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& alpha,
                            const Tensor& d_out, const Tensor& d_z);

}  // namespace gatcore::cpu
