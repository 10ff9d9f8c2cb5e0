#version 450
#extension GL_GOOGLE_include_directive : require
// out[s,c] = max over the rows of segment s (seg_ptr offsets) of x[:,c], argmax
// saved (int32 row index). The first maximum wins ties; the first NaN wins
// over numbers. An empty segment gives 0 and argmax -1. One invocation per (s, c).
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint S; uint C; VIEW(x); VIEW(o); VIEW(am); } pc;
BUF(0, x);
BUF(1, o);
IBUFW(2, am);
IBUF(3, seg);
void main() {
  uint id = flat_id();
  if (id >= pc.S * pc.C) return;
  uint s = id / pc.C, c = id % pc.C;
  uint r0 = uint(SB(seg)[s]), r1 = uint(SB(seg)[s + 1u]);
  float best = 0.0;
  int idx = -1;
  if (r0 < r1) {
    best = SB(x)[AT(x, r0, c)];
    idx = int(r0);
    STRIDED_FOR(r, r0 + 1u, r1, 1u) {
      float v = SB(x)[AT(x, r, c)];
      if (v > best || (isnan(v) && !isnan(best))) {
        best = v;
        idx = int(r);
      }
    }
  }
  SB(o)[AT(o, s, c)] = best;
  SB(am)[AT(am, s, c)] = idx;
}
