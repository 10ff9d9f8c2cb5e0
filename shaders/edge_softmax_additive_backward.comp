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
  uint b = uint(indptr[i]), e1 = uint(indptr[i + 1u]);
  float S = 0.0;
  for (uint e = b; e < e1; ++e) S += alpha[AT(alpha, e, k)] * dalpha[AT(dalpha, e, k)];
  float li = el[AT(el, i, k)];
  float acc = 0.0;
  for (uint e = b; e < e1; ++e) {
    float ds = alpha[AT(alpha, e, k)] * (dalpha[AT(dalpha, e, k)] - S);
    float g = leaky_grad(li + er[AT(er, uint(indices[e]), k)], ds, pc.slope);
    gs[AT(gs, e, k)] = g;
    acc += g;
  }
  if (pc.has_del != 0u && b != e1) del[AT(del, i, k)] += acc;
}
