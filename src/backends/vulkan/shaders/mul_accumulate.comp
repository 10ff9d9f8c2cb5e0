#version 450
#extension GL_GOOGLE_include_directive : require
// d_a += b ⊙ d_y
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(b); VIEW(dy); VIEW(da); } pc;
BUF(0, b);
BUF(1, dy);
BUF(2, da);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(da)[AT(da, r, c)] += SB(b)[AT(b, r, c)] * SB(dy)[AT(dy, r, c)];
}
