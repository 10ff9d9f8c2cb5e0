#version 450
#extension GL_GOOGLE_include_directive : require
// y[i,:] = softmax(x[i,:]) over columns with mask[0,c] != 0 (others 0); one
// subgroup per row. An all-masked row gives 0.
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(x); VIEW(mask); VIEW(y); uint has_mask; } pc;
BUF(0, x);
BUF(1, mask);
BUF(2, y);
bool on(uint c) { return pc.has_mask == 0u || SB(mask)[pc.mask_off + c] != 0.0; }
void main() {
  uint r = subgroup_item();
  if (r >= pc.rows) return;
  uint lane = subgroup_lane();
  float m = -1.0 / 0.0;
  STRIDED_FOR(c, lane, pc.cols, SUBGROUP_SIZE)
    if (on(c)) m = max(m, SB(x)[AT(x, r, c)]);
  m = subgroupMax(m);
  float s = 0.0;
  STRIDED_FOR(c, lane, pc.cols, SUBGROUP_SIZE)
    if (on(c)) s += exp(SB(x)[AT(x, r, c)] - m);
  s = subgroupAdd(s);
  float inv = s > 0.0 ? 1.0 / s : 0.0;
  STRIDED_FOR(c, lane, pc.cols, SUBGROUP_SIZE)
    SB(y)[AT(y, r, c)] = on(c) ? exp(SB(x)[AT(x, r, c)] - m) * inv : 0.0;
}
