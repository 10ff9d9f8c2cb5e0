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
  for (uint c = lane; c < pc.cols; c += SUBGROUP_SIZE) d += y[AT(y, r, c)] * dy[AT(dy, r, c)];
  d = subgroupAdd(d);
  for (uint c = lane; c < pc.cols; c += SUBGROUP_SIZE)
    dx[AT(dx, r, c)] += y[AT(y, r, c)] * (dy[AT(dy, r, c)] - d);
}
