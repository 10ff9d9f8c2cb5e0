#version 450
#extension GL_GOOGLE_include_directive : require
// d_x[s,c] += Σ_{i in segment s} d_out[i,c]; one invocation per (s, c).
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint S; uint C; VIEW(dout); VIEW(dx); } pc;
BUF(0, dout);
BUF(1, dx);
IBUF(2, seg);
void main() {
  uint id = flat_id();
  if (id >= pc.S * pc.C) return;
  uint s = id / pc.C, c = id % pc.C;
  float acc = 0.0;
  STRIDED_FOR(r, uint(SB(seg)[s]), uint(SB(seg)[s + 1u]), 1u) acc += SB(dout)[AT(dout, r, c)];
  SB(dx)[AT(dx, s, c)] += acc;
}
