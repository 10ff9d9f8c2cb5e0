#pragma once
// Pooling used by NeuroSkinning:
// - segment max: the max over the nodes of each graph of a batch (segments
//   given by node offsets seg_ptr), with the argmax saved for backward, and
//   its broadcast back to every node of the segment;
// - neighbour mean: out[i] = mean of x[j] over the neighbour set of i given as
//   a second CSR graph (the k geodesically nearest vertices); that graph is
//   square over the same nodes. Kernels check array sizes only; index ranges
//   are CsrGraph::validate()'s job (the graph builders guarantee them).
#include <cstdint>
#include <span>

#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// x: [n, C], out: [S, C], argmax: [S, C] int32 (node index). An empty segment
// gives 0 and argmax -1 (no gradient).
void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out,
                         const Tensor& argmax);
// d_x[argmax[s,c], c] += d_out[s,c]. Deterministic: parallel over segments and
// columns, each (s, c) has one target.
void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x);

// out[i] = x[segment(i)]    x: [S, C], out: [n, C]
void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out);
// d_x[s] += Σ_{i in s} d_out[i]
void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg_ptr, const Tensor& d_x);

// out[i] = (1/|N(i)|) Σ_{j in N(i)} x[j]; zero for an empty N(i).
void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out);
// d_x[j] += Σ_{i: j in N(i)} d_out[i] / |N(i)|   (gather over the transpose)
void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x);

}  // namespace gatcore::cpu
