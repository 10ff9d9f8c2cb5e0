#version 450
#extension GL_GOOGLE_include_directive : require
// Pass 2: d_h[i,c] += Σ_{e=(j->i)} g[e,k] h[j,c] + Σ_{e=(i->d)} g[e,k] h[d,c], k = c / F
// (the second sum gathered over the transpose).
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(h); VIEW(gs); VIEW(dh); } pc;
BUF(0, h);
BUF(1, gs);
BUF(2, dh);
IBUF(3, indptr);
IBUF(4, indices);
IBUF(5, out_ptr);
IBUF(6, out_dst);
IBUF(7, out_edge);
void main() {
  uint id = flat_id();
  uint C = pc.H * pc.F;
  if (id >= pc.n * C) return;
  uint i = id / C, c = id % C, k = c / pc.F;
  float acc = 0.0;
  STRIDED_FOR(e, uint(SB(indptr)[i]), uint(SB(indptr)[i + 1u]), 1u) acc += SB(gs)[AT(gs, e, k)] * SB(h)[AT(h, uint(SB(indices)[e]), c)];
  STRIDED_FOR(t, uint(SB(out_ptr)[i]), uint(SB(out_ptr)[i + 1u]), 1u)
    acc += SB(gs)[AT(gs, uint(SB(out_edge)[t]), k)] * SB(h)[AT(h, uint(SB(out_dst)[t]), c)];
  SB(dh)[AT(dh, i, c)] += acc;
}
