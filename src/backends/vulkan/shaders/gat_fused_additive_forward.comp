#version 450
#extension GL_GOOGLE_include_directive : require
// Fused additive graph attention, one subgroup per (destination i, head k):
// pass 1 the row max and sum of exp(LeakyReLU(el_i + er_j) - max) (O(1) per
// edge, every lane the same values); pass 2 writes alpha (first lane) and
// out[i, kF+f] = Σ_e alpha_e z[j, kF+f] with the lanes splitting f. Only alpha
// [E, H] is stored. Rows without edges give 0.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(z); VIEW(el); VIEW(er); VIEW(o); VIEW(alpha); float slope; } pc;
BUF(0, z);
BUF(1, el);
BUF(2, er);
BUF(3, o);
BUF(4, alpha);
IBUF(5, indptr);
IBUF(6, indices);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H, lane = subgroup_lane();
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float li = SB(el)[AT(el, i, k)];
  float m = -1.0 / 0.0, s = 0.0;
  for (uint e = b; e < e1; ++e) {
    float x = leaky(li + SB(er)[AT(er, uint(SB(indices)[e]), k)], pc.slope);
    float mn = max(m, x);
    s = s * exp(m - mn) + exp(x - mn);
    m = mn;
  }
  float inv = s > 0.0 ? 1.0 / s : 0.0;
  for (uint f0 = 0u; f0 < pc.F; f0 += SUBGROUP_SIZE) {
    uint f = f0 + lane;
    float acc = 0.0;
    for (uint e = b; e < e1; ++e) {
      uint j = uint(SB(indices)[e]);
      float p = exp(leaky(li + SB(er)[AT(er, j, k)], pc.slope) - m) * inv;
      if (f0 == 0u && lane == 0u) SB(alpha)[AT(alpha, e, k)] = p;
      if (f < pc.F) acc += p * SB(z)[AT(z, j, k * pc.F + f)];
    }
    if (f < pc.F) SB(o)[AT(o, i, k * pc.F + f)] = acc;
  }
}
