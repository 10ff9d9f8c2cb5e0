// Shared by every compute shader: extensions, element type, specialisation
// constants and dispatch indexing helpers.
//   constant_id 0: SUBGROUP_SIZE (the device's; never hard-coded)
//   constant_id 1: workgroup size (local_size_x), a multiple of SUBGROUP_SIZE
// Large dispatches are 2-D (x up to 65535 groups); flat_id() linearises them.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#ifndef ELEM
#define ELEM float
#endif
layout(constant_id = 0) const uint SUBGROUP_SIZE = 32u;
#ifndef GATCORE_FIXED_LOCAL_SIZE
layout(local_size_x_id = 1) in;
#endif

uint flat_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }
uint flat_id() { return flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x; }
// One subgroup per work item (a row, a (row, head) pair, ...).
uint subgroup_item() { return flat_group() * (gl_WorkGroupSize.x / SUBGROUP_SIZE) + gl_SubgroupID; }
uint subgroup_lane() { return gl_SubgroupInvocationID; }

// tanh that never overflows (exp of a non-positive argument only).
float safe_tanh(float x) {
  float t = exp(-2.0 * abs(x));
  float r = (1.0 - t) / (1.0 + t);
  return x < 0.0 ? -r : r;
}
float leaky(float x, float slope) { return x > 0.0 ? x : x * slope; }
float leaky_grad(float x, float d, float slope) { return x > 0.0 ? d : d * slope; }
