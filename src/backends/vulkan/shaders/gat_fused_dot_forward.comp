#version 450
#extension GL_GOOGLE_include_directive : require
// Fused dot-product graph attention, one subgroup per (destination i, head k):
// pass 1 computes each logit scale <z_i^k, z_j^k> (lanes split the features,
// subgroupAdd), keeps an online max / sum and parks the logit in alpha;
// pass 2 turns the parked logits into alpha and accumulates
// out[i, kF+f] = Σ_e alpha_e z[j, kF+f] with the lanes splitting f.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(z); VIEW(o); VIEW(alpha); float scale; } pc;
BUF(0, z);
BUF(1, o);
// coherent: the first lane parks the logits here for the whole subgroup.
BUFC(2, alpha);
IBUF(3, indptr);
IBUF(4, indices);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H, lane = subgroup_lane();
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float m = -1.0 / 0.0, s = 0.0;
  for (uint e = b; e < e1; ++e) {
    uint j = uint(SB(indices)[e]);
    float d = 0.0;
    for (uint f = lane; f < pc.F; f += SUBGROUP_SIZE) d += SB(z)[AT(z, i, k * pc.F + f)] * SB(z)[AT(z, j, k * pc.F + f)];
    float x = pc.scale * subgroupAdd(d);
    float mn = max(m, x);
    s = s * exp(m - mn) + exp(x - mn);
    m = mn;
    if (lane == 0u) SB(alpha)[AT(alpha, e, k)] = x;
  }
  // Make the first lane's parked logits visible to the whole subgroup.
  subgroupMemoryBarrierBuffer();
  subgroupBarrier();
  float inv = s > 0.0 ? 1.0 / s : 0.0;
  for (uint f0 = 0u; f0 < pc.F; f0 += SUBGROUP_SIZE) {
    uint f = f0 + lane;
    float acc = 0.0;
    for (uint e = b; e < e1; ++e) {
      float p = exp(SB(alpha)[AT(alpha, e, k)] - m) * inv;
      if (f < pc.F) acc += p * SB(z)[AT(z, uint(SB(indices)[e]), k * pc.F + f)];
    }
    if (f < pc.F) SB(o)[AT(o, i, k * pc.F + f)] = acc;
  }
  subgroupMemoryBarrierBuffer();
  subgroupBarrier();
  if (lane == 0u)
    for (uint e = b; e < e1; ++e) SB(alpha)[AT(alpha, e, k)] = exp(SB(alpha)[AT(alpha, e, k)] - m) * inv;
}
