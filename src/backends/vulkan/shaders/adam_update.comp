#version 450
#extension GL_GOOGLE_include_directive : require
// Adam with bias correction c1 = 1/(1-b1^t), c2 = 1/(1-b2^t) (src/backends/cpu/optimizer.hpp)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push {
  uint rows; uint cols; VIEW(p); VIEW(g); VIEW(m); VIEW(v); float lr; float b1; float b2; float eps; float wd; float c1; float c2;
} pc;
BUF(0, p);
BUF(1, g);
BUF(2, m);
BUF(3, v);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float pv = SB(p)[AT(p, r, c)];
  float gc = SB(g)[AT(g, r, c)] + pc.wd * pv;
  float mv = pc.b1 * SB(m)[AT(m, r, c)] + (1.0 - pc.b1) * gc;
  float vv = pc.b2 * SB(v)[AT(v, r, c)] + (1.0 - pc.b2) * gc * gc;
  SB(m)[AT(m, r, c)] = mv;
  SB(v)[AT(v, r, c)] = vv;
  SB(p)[AT(p, r, c)] = pv - pc.lr * (mv * pc.c1) / (sqrt(vv * pc.c2) + pc.eps);
}
