#version 450
#extension GL_GOOGLE_include_directive : require
// d_x += scale * s[0,0]
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(s); VIEW(dx); float scale; } pc;
BUF(0, s);
BUF(1, dx);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(dx)[AT(dx, r, c)] += pc.scale * SB(s)[pc.s_off];
}
