#version 450
#extension GL_GOOGLE_include_directive : require
// out[0,0] = Σ t log(t / max(p, eps)) / rows, 0 log 0 = 0   (one workgroup)
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(p); VIEW(t); VIEW(o); float eps; } pc;
BUF(0, p);
BUF(1, t);
BUF(2, o);
void main() {
  float s = 0.0;
  uint n = pc.rows * pc.cols;
  STRIDED_FOR(i, gl_LocalInvocationID.x, n, gl_WorkGroupSize.x) {
    uint r = i / pc.cols, c = i % pc.cols;
    float tc = SB(t)[AT(t, r, c)];
    if (tc > 0.0) {
      float pv = SB(p)[AT(p, r, c)];
      float pc_ = pv > pc.eps ? pv : (isnan(pv) ? pv : pc.eps);
      s += tc * (log(tc) - log(pc_));
    }
  }
  s = workgroup_sum(s);
  if (gl_LocalInvocationID.x == 0u) SB(o)[pc.o_off] = pc.rows == 0u ? 0.0 : s / float(pc.rows);
}
