#version 450
#extension GL_GOOGLE_include_directive : require
// d_x += f'(x) ⊙ d_y, from x or (tanh / relu / leaky_relu) y, whichever is bound.
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push {
  uint rows; uint cols; VIEW(x); VIEW(y); VIEW(dy); VIEW(dx); uint act; float slope; uint has_x; uint has_y;
} pc;
BUF(0, x);
BUF(1, y);
BUF(2, dy);
BUF(3, dx);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float g = SB(dy)[AT(dy, r, c)];
  float d = g;
  if (pc.act == 1u) {
    float t = pc.has_y != 0u ? SB(y)[AT(y, r, c)] : safe_tanh(SB(x)[AT(x, r, c)]);
    d = (1.0 - t) * (1.0 + t) * g;
  } else if (pc.act == 2u) {
    float t = safe_tanh(SB(x)[AT(x, r, c)]);
    d = t * t * g;
  } else if (pc.act == 3u || pc.act == 4u) {
    float s = pc.has_x != 0u ? SB(x)[AT(x, r, c)] : SB(y)[AT(y, r, c)];
    float neg = pc.act == 4u ? 0.0 : pc.slope;
    d = s > 0.0 ? g : neg * g;
  }
  SB(dx)[AT(dx, r, c)] += d;
}
