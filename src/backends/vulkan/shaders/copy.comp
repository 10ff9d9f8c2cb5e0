#version 450
#extension GL_GOOGLE_include_directive : require
// dst = src, both strided (src/backends/cpu/dense_concat.hpp concat_copy_forward)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(s); VIEW(d); } pc;
BUF(0, s);
BUF(1, d);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(d)[AT(d, r, c)] = SB(s)[AT(s, r, c)];
}
