#version 450
#extension GL_GOOGLE_include_directive : require
// y = alpha*a + beta*b   (y may alias a or b)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(a); VIEW(b); VIEW(y); float alpha; float beta; } pc;
BUF(0, a);
BUF(1, b);
BUF(2, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float av = SB(a)[AT(a, r, c)], bv = SB(b)[AT(b, r, c)];
  SB(y)[AT(y, r, c)] = pc.beta == 0.0 ? pc.alpha * av : pc.alpha * av + pc.beta * bv;
}
