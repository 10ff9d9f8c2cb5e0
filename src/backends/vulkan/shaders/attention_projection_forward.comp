#version 450
#extension GL_GOOGLE_include_directive : require
// el[i,k] = <a_l[k,:], z[i,kF:(k+1)F]>, er likewise with a_r; one subgroup per (i, k).
#include "common.glsl"
#include "elementwise.glsl"
layout(push_constant) uniform Push { uint n; uint H; uint F; VIEW(z); VIEW(al); VIEW(ar); VIEW(el); VIEW(er); } pc;
BUF(0, z);
BUF(1, al);
BUF(2, ar);
BUF(3, el);
BUF(4, er);
void main() {
  uint item = subgroup_item();
  if (item >= pc.n * pc.H) return;
  uint i = item / pc.H, k = item % pc.H;
  float sl = 0.0, sr = 0.0;
  for (uint f = subgroup_lane(); f < pc.F; f += SUBGROUP_SIZE) {
    float zv = SB(z)[AT(z, i, k * pc.F + f)];
    sl += SB(al)[AT(al, k, f)] * zv;
    sr += SB(ar)[AT(ar, k, f)] * zv;
  }
  sl = subgroupAdd(sl);
  sr = subgroupAdd(sr);
  if (subgroupElect()) {
    SB(el)[AT(el, i, k)] = sl;
    SB(er)[AT(er, i, k)] = sr;
  }
}
