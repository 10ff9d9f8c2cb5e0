#version 450
#extension GL_GOOGLE_include_directive : require
// out[i,c] = x[segment(i), c]; the segment of row i by binary search in seg_ptr.
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint n; uint C; uint S; VIEW(x); VIEW(o); } pc;
BUF(0, x);
BUF(1, o);
IBUF(2, seg);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.C) return;
  uint i = id / pc.C, c = id % pc.C;
  // The last s with seg[s] <= i (segments may be empty).
  uint lo = 0u, hi = pc.S;  // invariant: seg[lo] <= i < seg[hi]
  while (hi - lo > 1u) {
    uint mid = (lo + hi) / 2u;
    if (uint(SB(seg)[mid]) <= i) lo = mid; else hi = mid;
  }
  SB(o)[AT(o, i, c)] = SB(x)[AT(x, lo, c)];
}
