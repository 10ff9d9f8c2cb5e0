#version 450
#extension GL_GOOGLE_include_directive : require
// C = alpha * op(A) op(B) + beta * C, op(X) = X or X^T (push constants ta, tb).
// 64x64 output tiles per 256-invocation workgroup, 16-deep K tiles staged in
// shared memory, a 4x4 register block per invocation. beta == 0 ignores C.
#define GATCORE_FIXED_LOCAL_SIZE
#include "common.glsl"
#include "elementwise.glsl"
layout(local_size_x = 16, local_size_y = 16) in;
layout(push_constant) uniform Push {
  uint M; uint N; uint K; VIEW(a); VIEW(b); VIEW(c); uint ta; uint tb; float alpha; float beta;
} pc;
BUF(0, A);
BUF(1, B);
BUF(2, C);
const uint TM = 64u, TN = 64u, TK = 16u;
shared float As[TK][TM];
shared float Bs[TK][TN];
float load_a(uint i, uint k) {  // op(A)[i, k]
  if (i >= pc.M || k >= pc.K) return 0.0;
  return pc.ta != 0u ? SB(A)[AT(a, k, i)] : SB(A)[AT(a, i, k)];
}
float load_b(uint k, uint j) {  // op(B)[k, j]
  if (k >= pc.K || j >= pc.N) return 0.0;
  return pc.tb != 0u ? SB(B)[AT(b, j, k)] : SB(B)[AT(b, k, j)];
}
void main() {
  uint tx = gl_LocalInvocationID.x, ty = gl_LocalInvocationID.y;
  uint tid = ty * 16u + tx;
  uint row0 = gl_WorkGroupID.y * TM, col0 = gl_WorkGroupID.x * TN;
  float acc[4][4];
  for (uint i = 0u; i < 4u; ++i)
    for (uint j = 0u; j < 4u; ++j) acc[i][j] = 0.0;
  for (uint k0 = 0u; k0 < pc.K; k0 += TK) {
    // 256 invocations load 16x64 of A and of B: 4 elements each.
    for (uint l = 0u; l < 4u; ++l) {
      uint e = tid + l * 256u;
      uint kk = e / TM, mm = e % TM;
      As[kk][mm] = load_a(row0 + mm, k0 + kk);
      Bs[kk][mm] = load_b(k0 + kk, col0 + mm);
    }
    barrier();
    for (uint kk = 0u; kk < TK; ++kk) {
      float av[4], bv[4];
      for (uint i = 0u; i < 4u; ++i) av[i] = As[kk][ty + 16u * i];
      for (uint j = 0u; j < 4u; ++j) bv[j] = Bs[kk][tx + 16u * j];
      for (uint i = 0u; i < 4u; ++i)
        for (uint j = 0u; j < 4u; ++j) acc[i][j] += av[i] * bv[j];
    }
    barrier();
  }
  for (uint i = 0u; i < 4u; ++i) {
    uint r = row0 + ty + 16u * i;
    if (r >= pc.M) continue;
    for (uint j = 0u; j < 4u; ++j) {
      uint c = col0 + tx + 16u * j;
      if (c >= pc.N) continue;
      uint idx = AT(c, r, c);
      SB(C)[idx] = pc.beta == 0.0 ? pc.alpha * acc[i][j] : pc.alpha * acc[i][j] + pc.beta * SB(C)[idx];
    }
  }
}
