#version 450
#extension GL_GOOGLE_include_directive : require
// d_alpha[e,k] = <d_out_i^k, z_j^k> (overwritten); one subgroup per (i, k).
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(dout); VIEW(z); VIEW(dalpha); } pc;
BUF(0, dout);
BUF(1, z);
BUF(2, dalpha);
IBUF(3, indptr);
IBUF(4, indices);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H;
  for (uint e = uint(SB(indptr)[i]); e < uint(SB(indptr)[i + 1u]); ++e) {
    uint j = uint(SB(indices)[e]);
    float d = 0.0;
    for (uint f = subgroup_lane(); f < pc.F; f += SUBGROUP_SIZE) d += SB(dout)[AT(dout, i, k * pc.F + f)] * SB(z)[AT(z, j, k * pc.F + f)];
    d = subgroupAdd(d);
    if (subgroupElect()) SB(dalpha)[AT(dalpha, e, k)] = d;
  }
}
