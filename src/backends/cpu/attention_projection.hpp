#pragma once
// Additive GAT attention split into destination and source halves:
//   el[i,k] = <a_l[k,:], z[i, k*F:(k+1)*F]>   (the aggregating node i)
//   er[j,k] = <a_r[k,:], z[j, k*F:(k+1)*F]>   (the neighbour j)
// so the edge logit LeakyReLU(el[i,k] + er[j,k]) costs O(1) per edge.
// z: [n, H*F], a_l / a_r: [H, F], el / er: [n, H].
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/inference.hpp"

namespace gatcore::cpu {

void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                  const Tensor& er);

// Accumulates: d_z += d_el ⊗ a_l + d_er ⊗ a_r (per head),
//              d_al[k,:] += Σ_i d_el[i,k] z_i^k,  d_ar likewise.
// Any of d_z / d_al / d_ar may be undefined (not wanted).
void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& d_el,
                                   const Tensor& d_er, const Tensor& d_z, const Tensor& d_al, const Tensor& d_ar);

}  // namespace gatcore::cpu
