#version 450
#extension GL_GOOGLE_include_directive : require
// Per (i, k): ds_e = alpha (d_alpha - Σ_row alpha d_alpha), g_e = ds_e * LeakyReLU'(el_i + er_j);
// d_el[i,k] += Σ_row g_e, and g is stored in `gs` ([E, H]) for the transpose gather into d_er.
#include "common.glsl"
#include "elementwise.glsl"
#include "graph.glsl"
layout(push_constant) uniform Push {
  uint n; uint H; VIEW(el); VIEW(er); VIEW(alpha); VIEW(dalpha); VIEW(del); VIEW(gs); float slope; uint has_del;
} pc;
BUF(0, el);
BUF(1, er);
BUF(2, alpha);
BUF(3, dalpha);
BUF(4, del);
BUF(5, gs);
IBUF(6, indptr);
IBUF(7, indices);
void main() {
  uint id = flat_id();
  if (id >= pc.n * pc.H) return;
  uint i = id / pc.H, k = id % pc.H;
  uint b = uint(SB(indptr)[i]), e1 = uint(SB(indptr)[i + 1u]);
  float S = 0.0;
  STRIDED_FOR(e, b, e1, 1u) S += SB(alpha)[AT(alpha, e, k)] * SB(dalpha)[AT(dalpha, e, k)];
  float li = SB(el)[AT(el, i, k)];
  float acc = 0.0;
  STRIDED_FOR(e, b, e1, 1u) {
    float ds = SB(alpha)[AT(alpha, e, k)] * (SB(dalpha)[AT(dalpha, e, k)] - S);
    float g = leaky_grad(li + SB(er)[AT(er, uint(SB(indices)[e]), k)], ds, pc.slope);
    SB(gs)[AT(gs, e, k)] = g;
    acc += g;
  }
  if (pc.has_del != 0u && b != e1) SB(del)[AT(del, i, k)] += acc;
}
