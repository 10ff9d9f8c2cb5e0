#version 450
#extension GL_GOOGLE_include_directive : require
// y[i,:] += bias[0,:]
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(bias); VIEW(y); } pc;
BUF(0, bias);
BUF(1, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  SB(y)[AT(y, r, c)] += SB(bias)[pc.bias_off + c];
}
