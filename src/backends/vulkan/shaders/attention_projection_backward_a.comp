#version 450
#extension GL_GOOGLE_include_directive : require
// d_al[k,f] += Σ_i d_el[i,k] z[i,kF+f], d_ar likewise: one workgroup per (k, f).
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push {
  uint n; uint H; uint F; VIEW(z); VIEW(del); VIEW(der); VIEW(dal); VIEW(dar); uint has_dal; uint has_dar;
} pc;
BUF(0, z);
BUF(1, del);
BUF(2, der);
BUF(3, dal);
BUF(4, dar);
void main() {
  uint g = flat_group();
  if (g >= pc.H * pc.F) return;
  uint k = g / pc.F, f = g % pc.F;
  float sl = 0.0, sr = 0.0;
  STRIDED_FOR(i, gl_LocalInvocationID.x, pc.n, gl_WorkGroupSize.x) {
    float zv = SB(z)[AT(z, i, k * pc.F + f)];
    if (pc.has_dal != 0u) sl += SB(del)[AT(del, i, k)] * zv;
    if (pc.has_dar != 0u) sr += SB(der)[AT(der, i, k)] * zv;
  }
  sl = workgroup_sum(sl);
  sr = workgroup_sum(sr);
  if (gl_LocalInvocationID.x == 0u) {
    if (pc.has_dal != 0u) SB(dal)[AT(dal, k, f)] += sl;
    if (pc.has_dar != 0u) SB(dar)[AT(dar, k, f)] += sr;
  }
}
