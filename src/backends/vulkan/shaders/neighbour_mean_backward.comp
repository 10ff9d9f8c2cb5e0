#version 450
#extension GL_GOOGLE_include_directive : require
// d_x[j,c] += Σ_{i: j in N(i)} d_out[i,c] / |N(i)|   (gather over the transpose)
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint C; VIEW(dout); VIEW(dx); } pc;
BUF(0, dout);
BUF(1, dx);
IBUF(2, indptr);
IBUF(3, out_ptr);
IBUF(4, out_dst);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.C) return;
  uint j = id / pc.C, c = id % pc.C;
  float acc = 0.0;
  STRIDED_FOR(t, uint(SB(out_ptr)[j]), uint(SB(out_ptr)[j + 1u]), 1u) {
    uint i = uint(SB(out_dst)[t]);
    acc += SB(dout)[AT(dout, i, c)] / float(SB(indptr)[i + 1u] - SB(indptr)[i]);
  }
  SB(dx)[AT(dx, j, c)] += acc;
}
