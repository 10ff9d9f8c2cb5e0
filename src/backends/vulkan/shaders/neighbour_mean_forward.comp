#version 450
#extension GL_GOOGLE_include_directive : require
// out[i,c] = mean of x[j,c] over the neighbour row i of a CSR graph; 0 when empty.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint C; VIEW(x); VIEW(o); } pc;
BUF(0, x);
BUF(1, o);
IBUF(2, indptr);
IBUF(3, indices);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.C) return;
  uint i = id / pc.C, c = id % pc.C;
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float acc = 0.0;
  STRIDED_FOR(e, b, e1, 1u) acc += SB(x)[AT(x, uint(SB(indices)[e]), c)];
  SB(o)[AT(o, i, c)] = b == e1 ? 0.0 : acc / float(e1 - b);
}
