#version 450
#extension GL_GOOGLE_include_directive : require
// d_pred += d_out[0,0] * 2 (pred - target) / numel
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(p); VIEW(t); VIEW(g); VIEW(dp); float inv_n; } pc;
BUF(0, p);
BUF(1, t);
BUF(2, g);
BUF(3, dp);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float k = SB(g)[pc.g_off] * 2.0 * pc.inv_n;
  SB(dp)[AT(dp, r, c)] += k * (SB(p)[AT(p, r, c)] - SB(t)[AT(t, r, c)]);
}
