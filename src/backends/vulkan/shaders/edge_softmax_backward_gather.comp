#version 450
#extension GL_GOOGLE_include_directive : require
// d_x[j,k] += Σ_{edges e leaving j} g[e,k]   (gather over the transpose)
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; VIEW(gs); VIEW(dx); } pc;
BUF(0, gs);
BUF(1, dx);
IBUF(2, out_ptr);
IBUF(3, out_edge);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.H) return;
  uint j = id / pc.H, k = id % pc.H;
  uint b = uint(SB(out_ptr)[j]), e1 = uint(SB(out_ptr)[j + 1u]);
  if (b == e1) return;
  float acc = 0.0;
  STRIDED_FOR(t, b, e1, 1u) acc += SB(gs)[AT(gs, uint(SB(out_edge)[t]), k)];
  SB(dx)[AT(dx, j, k)] += acc;
}
