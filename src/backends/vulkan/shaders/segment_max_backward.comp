#version 450
#extension GL_GOOGLE_include_directive : require
// d_x[argmax[s,c], c] += d_out[s,c]; each (s, c) has its own target row (no atomics).
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint S; uint C; VIEW(dout); VIEW(am); VIEW(dx); } pc;
BUF(0, dout);
IBUF(1, am);
BUF(2, dx);
void main() {
  uint id = flat_id();
  if (id >= pc.S * pc.C) return;
  uint s = id / pc.C, c = id % pc.C;
  int r = SB(am)[AT(am, s, c)];
  if (r >= 0) SB(dx)[AT(dx, uint(r), c)] += SB(dout)[AT(dout, s, c)];
}
