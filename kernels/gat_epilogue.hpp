#pragma once
// The end of a GAT block on the deploy path (models/deploy.cpp), in one pass
// over the block's attention output `att` [n, kf] and self stream `self`
// [n, S] (S = 0: undefined), W = kf + S columns:
//   y = affine(tanhshrink([att | self + self_b]))
// affine: BatchNorm's prepared eval map ((x - mean) * scale + shift, as
// batchnorm_affine_forward; undefined mean = none). The composition it
// replaces (copying both streams into one [n, W] tensor, add_row_bias on the
// self columns, activation_forward tanhshrink, batchnorm_affine_forward, and
// on the bf16 path bf16_pairs) reads and writes the block's output four or
// five times; on a 10k-vertex frame those passes were a quarter of the bf16
// frame's time and a sixth of the fp32 one's. Same arithmetic as the
// composition at the AVX-512 level (tested bitwise).
//
// Two destinations (gat_epilogue_impl.inc holds the shared arithmetic):
// - fp32 (gat_epilogue.cpp): y into `out` [n, W] (any row stride; must not
//   overlap the inputs). AVX-512 only: gat_epilogue_supported() says whether
//   the active SIMD level is AVX-512; below it the deploy path runs the
//   composition (its kernels have AVX2 and scalar versions).
// - bf16 (gat_epilogue_bf16.cpp): y only as bf16 pair words (row i at dst +
//   i * ld, ceil(W/2) words: bf16_pairs' layout), the form every later
//   product of the block's DenseNet buffer reads. AVX512_BF16 CPUs only
//   (bf16_supported(); the deploy path uses bf16 nowhere else).
// Both throw when called where they cannot run.
#include <cstdint>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

bool gat_epilogue_supported();  // simd_level() is AVX-512

void gat_epilogue(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                  const Tensor& scale, const Tensor& shift, const Tensor& out);
void gat_epilogue_bf16(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                       const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld);

// The block's attention and the epilogue in one pass: att =
// gat_fused_additive_forward(g, z, el, er, slope) row by row
// (gat_fused_additive_forward_rows), each chunk of rows finished while still
// in L1, so neither att [n, kf] nor (for 8 heads of 8) the attention weights
// go through memory. Bitwise gat_fused_additive_forward followed by the
// epilogue (tested). alpha [E, H]: scratch (see
// gat_fused_additive_forward_rows).
void gat_attention_epilogue(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                            const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                            const Tensor& scale, const Tensor& shift, const Tensor& out);
void gat_attention_epilogue_bf16(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                                 const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                                 const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld);

}  // namespace gatcore::cpu
