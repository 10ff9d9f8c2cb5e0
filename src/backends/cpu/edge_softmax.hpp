#pragma once
// Per-head softmax of edge logits over each destination row of a CSR graph,
// numerically stable (row max subtracted). Rows without edges produce nothing
// (their aggregation is defined as zero).
//   additive: s_e = LeakyReLU(el[i,k] + er[j,k], slope)      (GAT / DenseGATs)
//   dot:      s_e = scale * <h_i^k, h_j^k>                      (NeuroSkinning)
// for the edge e = (j -> i). alpha: [E, H].
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                   const Tensor& alpha);
void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha);

// Softmax backward ds = alpha ⊙ (d_alpha − Σ_row alpha ⊙ d_alpha), then through
// the logits. Accumulates into d_el, d_er (additive) / d_h (dot); d_er and the
// source side of d_h are gathered through the transpose (no atomics).
void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                    const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el,
                                    const Tensor& d_er);
void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha,
                               const Tensor& d_alpha, const Tensor& d_h);

}  // namespace gatcore::cpu
