#version 450
#extension GL_GOOGLE_include_directive : require
// Row pass of the fused dot-product backward, one subgroup per (i, k):
// d_alpha_e = <d_out_i^k, z_j^k> formed on the fly (lanes split the
// features), then by the first lane g_e = scale alpha_e (d_alpha_e - Σ_row alpha d_alpha)
// into `gs` [E, H]; edge_softmax_dot_backward_h then adds the logit terms to
// d_z (both sides, the source side over the transpose) and aggregate_backward_z
// the aggregation term.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(z); VIEW(alpha); VIEW(dout); VIEW(gs); float scale; } pc;
BUF(0, z);
BUF(1, alpha);
BUF(2, dout);
BUF(3, gs);
IBUF(4, indptr);
IBUF(5, indices);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H, lane = subgroup_lane();
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float S = 0.0;
  for (uint e = b; e < e1; ++e) {
    uint j = uint(SB(indices)[e]);
    float d = 0.0;
    for (uint f = lane; f < pc.F; f += SUBGROUP_SIZE) d += SB(dout)[AT(dout, i, k * pc.F + f)] * SB(z)[AT(z, j, k * pc.F + f)];
    d = subgroupAdd(d);
    S += SB(alpha)[AT(alpha, e, k)] * d;
    if (lane == 0u) SB(gs)[AT(gs, e, k)] = d;
  }
  if (lane != 0u) return;
  for (uint e = b; e < e1; ++e)
    SB(gs)[AT(gs, e, k)] = pc.scale * SB(alpha)[AT(alpha, e, k)] * (SB(gs)[AT(gs, e, k)] - S);
}
