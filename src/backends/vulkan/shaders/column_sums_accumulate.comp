#version 450
#extension GL_GOOGLE_include_directive : require
// d_bias[0,c] += Σ_i d_y[i,c]: one workgroup per column, fixed-order reduction.
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(dy); VIEW(db); } pc;
BUF(0, dy);
BUF(1, db);
void main() {
  uint c = flat_group();
  if (c >= pc.cols) return;
  float s = 0.0;
  STRIDED_FOR(r, gl_LocalInvocationID.x, pc.rows, gl_WorkGroupSize.x) s += SB(dy)[AT(dy, r, c)];
  s = workgroup_sum(s);
  if (gl_LocalInvocationID.x == 0u) SB(db)[pc.db_off + c] += s;
}
