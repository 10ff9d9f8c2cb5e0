#version 450
#extension GL_GOOGLE_include_directive : require
// Pass 1 of the dot-product softmax backward, per (i, k):
// g[e,k] = scale * alpha (d_alpha - Σ_row alpha d_alpha)  (stored for pass 2,
// edge_softmax_dot_backward_h).
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; VIEW(alpha); VIEW(dalpha); VIEW(gs); float scale; } pc;
BUF(0, alpha);
BUF(1, dalpha);
BUF(2, gs);
IBUF(3, indptr);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.H) return;
  uint i = id / pc.H, k = id % pc.H;
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float S = 0.0;
  STRIDED_FOR(e, b, e1, 1u) S += SB(alpha)[AT(alpha, e, k)] * SB(dalpha)[AT(dalpha, e, k)];
  STRIDED_FOR(e, b, e1, 1u)
    SB(gs)[AT(gs, e, k)] = pc.scale * SB(alpha)[AT(alpha, e, k)] * (SB(dalpha)[AT(dalpha, e, k)] - S);
}
