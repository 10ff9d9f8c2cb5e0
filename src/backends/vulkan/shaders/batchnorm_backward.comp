#version 450
#extension GL_GOOGLE_include_directive : require
// BatchNorm1d backward, one workgroup per column. xhat = (x - mean) invstd;
// d_beta += Σ d_y, d_gamma += Σ d_y xhat;
// mode 0 (training, saved mean / invstd): d_x += gamma invstd (d_y - Σd_y/n - xhat Σd_y xhat/n);
// mode 1 (evaluation, running stats):     d_x += gamma invstd d_y.
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push {
  uint n; uint C; VIEW(x); VIEW(gamma); VIEW(mean); VIEW(stat); VIEW(dy); VIEW(dx); VIEW(dg); VIEW(db);
  uint mode; float eps; uint has_gamma; uint has_dx; uint has_dg; uint has_db;
} pc;
BUF(0, x);
BUF(1, gamma);
BUF(2, mean);
BUF(3, stat);
BUF(4, dy);
BUF(5, dx);
BUF(6, dg);
BUF(7, db);
void main() {
  uint c = flat_group();
  if (c >= pc.C) return;
  uint lid = gl_LocalInvocationID.x, W = gl_WorkGroupSize.x;
  float mu = SB(mean)[AT(mean, 0u, c)];
  float s = SB(stat)[AT(stat, 0u, c)];
  float invstd = pc.mode == 0u ? s : 1.0 / sqrt(s + pc.eps);
  float g = pc.has_gamma != 0u ? SB(gamma)[AT(gamma, 0u, c)] : 1.0;
  float a = 0.0, b = 0.0;
  STRIDED_FOR(r, lid, pc.n, W) {
    float d = SB(dy)[AT(dy, r, c)];
    a += d;
    b += d * (SB(x)[AT(x, r, c)] - mu) * invstd;
  }
  a = workgroup_sum(a);
  b = workgroup_sum(b);
  if (lid == 0u) {
    if (pc.has_db != 0u) SB(db)[AT(db, 0u, c)] += a;
    if (pc.has_dg != 0u) SB(dg)[AT(dg, 0u, c)] += b;
  }
  if (pc.has_dx == 0u) return;
  float k = g * invstd;
  float km = a / float(pc.n), kp = b / float(pc.n);
  STRIDED_FOR(r, lid, pc.n, W) {
    float d = SB(dy)[AT(dy, r, c)];
    if (pc.mode == 0u) {
      float xhat = (SB(x)[AT(x, r, c)] - mu) * invstd;
      SB(dx)[AT(dx, r, c)] += k * (d - km - xhat * kp);
    } else {
      SB(dx)[AT(dx, r, c)] += k * d;
    }
  }
}
