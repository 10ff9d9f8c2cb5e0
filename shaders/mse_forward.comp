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
  for (uint i = gl_LocalInvocationID.x; i < n; i += gl_WorkGroupSize.x) {
    uint r = i / pc.cols, c = i % pc.cols;
    float d = p[AT(p, r, c)] - t[AT(t, r, c)];
    s += d * d;
  }
  s = workgroup_sum(s);
  if (gl_LocalInvocationID.x == 0u) o[pc.o_off] = n == 0u ? 0.0 : s / float(n);
}
