#version 450
#extension GL_GOOGLE_include_directive : require
// y = value   (src/backends/cpu/elementwise.hpp fill)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(y); float value; } pc;
BUF(0, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(y)[AT(y, r, c)] = pc.value;
}
