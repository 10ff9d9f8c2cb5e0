#version 450
#extension GL_GOOGLE_include_directive : require
// out[0,0] = Σ x   (one workgroup; fixed-order reduction)
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(x); VIEW(o); } pc;
BUF(0, x);
BUF(1, o);
void main() {
  float s = 0.0;
  uint n = pc.rows * pc.cols;
  STRIDED_FOR(i, gl_LocalInvocationID.x, n, gl_WorkGroupSize.x) s += SB(x)[AT(x, i / pc.cols, i % pc.cols)];
  s = workgroup_sum(s);
  if (gl_LocalInvocationID.x == 0u) SB(o)[pc.o_off] = s;
}
