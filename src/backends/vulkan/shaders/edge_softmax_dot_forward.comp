#version 450
#extension GL_GOOGLE_include_directive : require
// alpha[e,k] = softmax over row i of scale <h_i^k, h_j^k>; one subgroup per
// (i, k): lanes split the feature dot products, the first lane normalises.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(h); VIEW(alpha); float scale; } pc;
BUF(0, h);
BUF(1, alpha);
IBUF(2, indptr);
IBUF(3, indices);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H;
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float m = -1.0 / 0.0;
  for (uint e = b; e < e1; ++e) {
    uint j = uint(SB(indices)[e]);
    float d = 0.0;
    for (uint f = subgroup_lane(); f < pc.F; f += SUBGROUP_SIZE) d += SB(h)[AT(h, i, k * pc.F + f)] * SB(h)[AT(h, j, k * pc.F + f)];
    float s = pc.scale * subgroupAdd(d);
    m = max(m, s);
    if (subgroupElect()) SB(alpha)[AT(alpha, e, k)] = s;
  }
  if (!subgroupElect() || b == e1) return;
  float sum = 0.0;
  for (uint e = b; e < e1; ++e) {
    float p = exp(SB(alpha)[AT(alpha, e, k)] - m);
    SB(alpha)[AT(alpha, e, k)] = p;
    sum += p;
  }
  float inv = 1.0 / sum;
  for (uint e = b; e < e1; ++e) SB(alpha)[AT(alpha, e, k)] *= inv;
}
