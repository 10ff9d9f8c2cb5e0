#version 450
#extension GL_GOOGLE_include_directive : require
// y += alpha * x
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(x); VIEW(y); float alpha; } pc;
BUF(0, x);
BUF(1, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(y)[AT(y, r, c)] += pc.alpha * SB(x)[AT(x, r, c)];
}
