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
  uint b = uint(indptr[i]), e1 = uint(indptr[i + 1u]);
  if (b == e1) return;
  float li = el[AT(el, i, k)];
  float m = -1.0 / 0.0;
  for (uint e = b; e < e1; ++e) m = max(m, leaky(li + er[AT(er, uint(indices[e]), k)], pc.slope));
  float s = 0.0;
  for (uint e = b; e < e1; ++e) {
    float p = exp(leaky(li + er[AT(er, uint(indices[e]), k)], pc.slope) - m);
    alpha[AT(alpha, e, k)] = p;
    s += p;
  }
  float inv = 1.0 / s;
  for (uint e = b; e < e1; ++e) alpha[AT(alpha, e, k)] *= inv;
}
