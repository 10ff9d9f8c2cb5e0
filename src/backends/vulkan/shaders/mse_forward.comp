#version 450
#extension GL_GOOGLE_include_directive : require
// out[0,0] = mean (pred - target)^2   (one workgroup)
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(p); VIEW(t); VIEW(o); } pc;
BUF(0, p);
BUF(1, t);
BUF(2, o);
void main() {
  float s = 0.0;
  uint n = pc.rows * pc.cols;
  STRIDED_FOR(i, gl_LocalInvocationID.x, n, gl_WorkGroupSize.x) {
    uint r = i / pc.cols, c = i % pc.cols;
    float d = SB(p)[AT(p, r, c)] - SB(t)[AT(t, r, c)];
    s += d * d;
  }
  s = workgroup_sum(s);
  if (gl_LocalInvocationID.x == 0u) SB(o)[pc.o_off] = n == 0u ? 0.0 : s / float(n);
}
