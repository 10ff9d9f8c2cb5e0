#version 450
#extension GL_GOOGLE_include_directive : require
// y = a ⊙ b
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(a); VIEW(b); VIEW(y); } pc;
BUF(0, a);
BUF(1, b);
BUF(2, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(y)[AT(y, r, c)] = SB(a)[AT(a, r, c)] * SB(b)[AT(b, r, c)];
}
