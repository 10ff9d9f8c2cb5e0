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
// Inference: the additive forward's output handed to `sink` in chunks of
// consecutive rows as each thread finishes them (out rows r0..r1 at rows +
// (i - r0) H F, a small per-thread buffer still in L1), instead of an [n, H F]
// tensor written and read back by the next pass. Bitwise the rows
// gat_fused_additive_forward gives. alpha [E, H] is scratch: H = F = 8 (the
// register path) stores no weights at all; other shapes write them there.
// Calls to sink come from the OpenMP threads, each chunk once.
using AttentionRowsSink = void (*)(void* ctx, std::int64_t r0, std::int64_t r1, const float* rows);
void gat_fused_additive_forward_rows(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                     float slope, const Tensor& alpha, AttentionRowsSink sink, void* ctx);
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
