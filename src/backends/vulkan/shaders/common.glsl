// Shared by every compute shader: extensions, element type, specialisation
// constants and dispatch indexing helpers.
//   constant_id 0: SUBGROUP_SIZE (the device's; never hard-coded)
//   constant_id 1: workgroup size (local_size_x), a multiple of SUBGROUP_SIZE
// Large dispatches are 2-D (x up to 65535 groups); flat_id() linearises them.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_EXT_control_flow_attributes : require
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
// Long strided loops: Mesa lavapipe (llvmpipe) ends an invocation's loops after
// 65535 iterations in total (LP_MAX_TGSI_LOOP_ITERATIONS: one counter shared by
// every loop of the shader), which a reduction over a large tensor exceeds.
// Such loops take STRIDE_UNROLL strides per iteration with an unrolled inner
// loop, visiting the same indices in the same order (results unchanged):
//   STRIDED_FOR(i, first, n, stride) { body using i }
const uint STRIDE_UNROLL = 16u;
#define STRIDED_FOR(i, first, n, stride)                                                   \
  for (uint i##_0 = (first); i##_0 < (n); i##_0 += (stride) * STRIDE_UNROLL)              \
    [[unroll]] for (uint i##_u = 0u, i = i##_0; i##_u < STRIDE_UNROLL; ++i##_u, i += (stride)) \
      if (i < (n))
