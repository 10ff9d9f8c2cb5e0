// Whole-workgroup sum: subgroupAdd, then the per-subgroup partials summed in a
// fixed order (deterministic). Every invocation must call it (uniform flow).
shared float red_partial[gl_WorkGroupSize.x];
float workgroup_sum(float v) {
  float s = subgroupAdd(v);
  if (subgroupElect()) red_partial[gl_SubgroupID] = s;
  barrier();
  float t = 0.0;
  for (uint i = 0u; i < gl_NumSubgroups; ++i) t += red_partial[i];
  barrier();
  return t;
}
