#version 450
#extension GL_GOOGLE_include_directive : require
// BatchNorm1d forward over the rows of x [n, C], one workgroup per column.
// mode 0 (training): batch mean / biased variance (two passes, fixed-order
// sums), saves mean and invstd, updates running stats (unbiased variance)
// with `momentum`; mode 1 (evaluation): running statistics.
// gamma / beta / saves / running stats may be unbound (has_* = 0).
#include "common.glsl"
#include "elementwise.glsl"
#include "reduce.glsl"
layout(push_constant) uniform Push {
  uint n; uint C; VIEW(x); VIEW(gamma); VIEW(beta); VIEW(y); VIEW(smean); VIEW(sinv); VIEW(rm); VIEW(rv);
  uint mode; float eps; float momentum; uint has_gamma; uint has_beta; uint has_smean; uint has_sinv; uint has_rm; uint has_rv;
} pc;
BUF(0, x);
BUF(1, gamma);
BUF(2, beta);
BUF(3, y);
BUF(4, smean);
BUF(5, sinv);
BUF(6, rm);
BUF(7, rv);
void main() {
  uint c = flat_group();
  if (c >= pc.C) return;
  uint lid = gl_LocalInvocationID.x, W = gl_WorkGroupSize.x;
  float mean, invstd;
  if (pc.mode == 0u) {
    float s = 0.0;
    STRIDED_FOR(r, lid, pc.n, W) s += SB(x)[AT(x, r, c)];
    mean = workgroup_sum(s) / float(pc.n);
    float q = 0.0;
    STRIDED_FOR(r, lid, pc.n, W) {
      float d = SB(x)[AT(x, r, c)] - mean;
      q += d * d;
    }
    float var = workgroup_sum(q) / float(pc.n);
    invstd = 1.0 / sqrt(var + pc.eps);
    if (lid == 0u) {
      if (pc.has_smean != 0u) SB(smean)[AT(smean, 0u, c)] = mean;
      if (pc.has_sinv != 0u) SB(sinv)[AT(sinv, 0u, c)] = invstd;
      float m = pc.momentum;
      if (pc.has_rm != 0u) SB(rm)[AT(rm, 0u, c)] = (1.0 - m) * SB(rm)[AT(rm, 0u, c)] + m * mean;
      if (pc.has_rv != 0u)
        SB(rv)[AT(rv, 0u, c)] = (1.0 - m) * SB(rv)[AT(rv, 0u, c)] + m * var * (float(pc.n) / float(pc.n - 1u));
    }
  } else {
    mean = pc.has_rm != 0u ? SB(rm)[AT(rm, 0u, c)] : 0.0;
    invstd = 1.0 / sqrt((pc.has_rv != 0u ? SB(rv)[AT(rv, 0u, c)] : 1.0) + pc.eps);
  }
  float g = pc.has_gamma != 0u ? SB(gamma)[AT(gamma, 0u, c)] : 1.0;
  float b = pc.has_beta != 0u ? SB(beta)[AT(beta, 0u, c)] : 0.0;
  float sc = invstd * g;
  STRIDED_FOR(r, lid, pc.n, W) SB(y)[AT(y, r, c)] = (SB(x)[AT(x, r, c)] - mean) * sc + b;
}
