#version 450
#extension GL_GOOGLE_include_directive : require
// alpha[e,k] = softmax over row i of LeakyReLU(el[i,k] + er[j,k]); one invocation per (i, k).
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push { uint n; uint H; VIEW(el); VIEW(er); VIEW(alpha); float slope; } pc;
BUF(0, el);
BUF(1, er);
BUF(2, alpha);
IBUF(3, indptr);
IBUF(4, indices);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.H) return;
  uint i = id / pc.H, k = id % pc.H;
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  if (b == e1) return;
  float li = SB(el)[AT(el, i, k)];
  float m = -1.0 / 0.0;
  STRIDED_FOR(e, b, e1, 1u) m = max(m, leaky(li + SB(er)[AT(er, uint(SB(indices)[e]), k)], pc.slope));
  float s = 0.0;
  STRIDED_FOR(e, b, e1, 1u) {
    float p = exp(leaky(li + SB(er)[AT(er, uint(SB(indices)[e]), k)], pc.slope) - m);
    SB(alpha)[AT(alpha, e, k)] = p;
    s += p;
  }
  float inv = 1.0 / s;
  STRIDED_FOR(e, b, e1, 1u) SB(alpha)[AT(alpha, e, k)] *= inv;
}
