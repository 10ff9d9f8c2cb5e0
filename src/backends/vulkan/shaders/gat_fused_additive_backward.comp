#version 450
#extension GL_GOOGLE_include_directive : require
// Row pass of the fused additive backward, one subgroup per (i, k):
// d_alpha_e = <d_out_i^k, z_j^k> is formed on the fly (lanes split the
// features) and never stored as such; the first lane then turns it into the
// logit gradient g_e = alpha_e (d_alpha_e - Σ_row alpha d_alpha) LeakyReLU'(el_i + er_j),
// accumulates d_el[i,k] and leaves g in `gs` [E, H] for the transpose gathers
// into d_er (edge_softmax_backward_gather). d_z is aggregate_backward_z's.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push {
  uint n; uint H; uint F; VIEW(z); VIEW(el); VIEW(er); VIEW(alpha); VIEW(dout); VIEW(del); VIEW(gs); float slope; uint has_del;
} pc;
BUF(0, z);
BUF(1, el);
BUF(2, er);
BUF(3, alpha);
BUF(4, dout);
BUF(5, del);
BUF(6, gs);
IBUF(7, indptr);
IBUF(8, indices);
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
    if (lane == 0u) SB(gs)[AT(gs, e, k)] = d;  // parked d_alpha, read back by this lane only
  }
  if (lane != 0u || b == e1) return;
  float li = SB(el)[AT(el, i, k)];
  float acc = 0.0;
  for (uint e = b; e < e1; ++e) {
    float ds = SB(alpha)[AT(alpha, e, k)] * (SB(gs)[AT(gs, e, k)] - S);
    float g = leaky_grad(li + SB(er)[AT(er, uint(SB(indices)[e]), k)], ds, pc.slope);
    SB(gs)[AT(gs, e, k)] = g;
    acc += g;
  }
  if (pc.has_del != 0u) SB(del)[AT(del, i, k)] += acc;
}
