#version 450
#extension GL_GOOGLE_include_directive : require
// out[i, kF+f] = Σ_{e=(j->i)} alpha[e,k] z[j, kF+f]; one invocation per output element.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(alpha); VIEW(z); VIEW(o); } pc;
BUF(0, alpha);
BUF(1, z);
BUF(2, o);
IBUF(3, indptr);
IBUF(4, indices);
void main() {
  uint id = flat_id();
  uint C = pc.H * pc.F;
  if (id >= pc.n * C) return;
  uint i = id / C, c = id % C, k = c / pc.F;
  float acc = 0.0;
  STRIDED_FOR(e, uint(SB(indptr)[i]), uint(SB(indptr)[i + 1u]), 1u) acc += SB(alpha)[AT(alpha, e, k)] * SB(z)[AT(z, uint(SB(indices)[e]), c)];
  SB(o)[AT(o, i, c)] = acc;
}
