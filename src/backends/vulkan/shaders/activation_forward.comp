#version 450
#extension GL_GOOGLE_include_directive : require
// y = f(x); f: 0 identity, 1 tanh, 2 tanhshrink, 3 leaky_relu, 4 relu (gatcore::Activation)
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint rows; uint cols; VIEW(x); VIEW(y); uint act; float slope; } pc;
BUF(0, x);
BUF(1, y);
void main() {
  uint i = flat_id();
  if (i >= pc.rows * pc.cols) return;
  uint r = i / pc.cols, c = i % pc.cols;
  float v = SB(x)[AT(x, r, c)];
  float o = v;
  if (pc.act == 1u) o = safe_tanh(v);
  else if (pc.act == 2u) o = v - safe_tanh(v);
  else if (pc.act == 3u) o = v < 0.0 ? pc.slope * v : v;
  else if (pc.act == 4u) o = v < 0.0 ? 0.0 : v;
  SB(y)[AT(y, r, c)] = o;
}
