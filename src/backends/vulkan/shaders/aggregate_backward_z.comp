#version 450
#extension GL_GOOGLE_include_directive : require
// d_z[j,c] += Σ_{e=(j->d)} alpha[e,k] d_out[d,c], k = c / F (gather over the transpose).
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(alpha); VIEW(dout); VIEW(dz); } pc;
BUF(0, alpha);
BUF(1, dout);
BUF(2, dz);
IBUF(3, out_ptr);
IBUF(4, out_dst);
IBUF(5, out_edge);
void main() {
  uint id = flat_id();
  uint C = pc.H * pc.F;
  if (id >= pc.n * C) return;
  uint j = id / C, c = id % C, k = c / pc.F;
  float acc = 0.0;
  STRIDED_FOR(t, uint(SB(out_ptr)[j]), uint(SB(out_ptr)[j + 1u]), 1u)
    acc += SB(alpha)[AT(alpha, uint(SB(out_edge)[t]), k)] * SB(dout)[AT(dout, uint(SB(out_dst)[t]), c)];
  SB(dz)[AT(dz, j, c)] += acc;
}
