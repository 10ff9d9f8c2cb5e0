#version 450
#extension GL_GOOGLE_include_directive : require
// d_z[i, kF+f] += d_el[i,k] a_l[k,f] + d_er[i,k] a_r[k,f]   (one invocation per element)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(del); VIEW(der); VIEW(al); VIEW(ar); VIEW(dz); } pc;
BUF(0, del);
BUF(1, der);
BUF(2, al);
BUF(3, ar);
BUF(4, dz);
void main() {
  uint id = flat_id();
  uint C = pc.H * pc.F;
  if (id >= pc.n * C) return;
  uint i = id / C, c = id % C, k = c / pc.F, f = c % pc.F;
  SB(dz)[AT(dz, i, c)] += SB(del)[AT(del, i, k)] * SB(al)[AT(al, k, f)] + SB(der)[AT(der, i, k)] * SB(ar)[AT(ar, k, f)];
}
