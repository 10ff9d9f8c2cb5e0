#version 450
#extension GL_GOOGLE_include_directive : require
// d_pred += d_out[0,0] * (-t / max(p, eps)) / rows
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(p); VIEW(t); VIEW(g); VIEW(dp); float eps; float inv_rows; } pc;
BUF(0, p);
BUF(1, t);
BUF(2, g);
BUF(3, dp);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float k = -SB(g)[pc.g_off] * pc.inv_rows;
  float pv = SB(p)[AT(p, r, c)];
  float pc_ = pv > pc.eps ? pv : (isnan(pv) ? pv : pc.eps);
  SB(dp)[AT(dp, r, c)] += k * (SB(t)[AT(t, r, c)] / pc_);
}
