#version 450
#extension GL_GOOGLE_include_directive : require
// d_x += y ⊙ (d_y − <y, d_y>_row); one subgroup per row.
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(y); VIEW(dy); VIEW(dx); } pc;
BUF(0, y);
BUF(1, dy);
BUF(2, dx);
void main() {
  uint r = subgroup_item();
  if (r >= pc.rows) return;
  uint lane = subgroup_lane();
  float d = 0.0;
  STRIDED_FOR(c, lane, pc.cols, SUBGROUP_SIZE) d += SB(y)[AT(y, r, c)] * SB(dy)[AT(dy, r, c)];
  d = subgroupAdd(d);
  STRIDED_FOR(c, lane, pc.cols, SUBGROUP_SIZE)
    SB(dx)[AT(dx, r, c)] += SB(y)[AT(y, r, c)] * (SB(dy)[AT(dy, r, c)] - d);
}
