#pragma once
// Multi-head aggregation (SpMM with per-edge, per-head weights):
//   out[i, k*F+f] = Σ_{e=(j->i)} alpha[e,k] * z[j, k*F+f]
// z: [n, H*F], alpha: [E, H], out: [n, H*F] (overwritten; zero for rows
// without edges).
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out);

// d_alpha[e,k] = <d_out_i^k, z_j^k>   (overwritten; may be undefined)
// d_z[j]      += Σ_{e=(j->i)} alpha[e,k] d_out_i^k   (gather over the transpose; may be undefined)
void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out,
                        const Tensor& d_alpha, const Tensor& d_z);

}  // namespace gatcore::cpu
