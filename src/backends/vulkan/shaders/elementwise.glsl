// Row-major strided 2-D views: element (r, c) of view v is buf[v.off + r*v.ld + c].
// Elementwise shaders run one invocation per element of a [rows, cols] range.
#define VIEW(name) uint name##_off; uint name##_ld
#define AT(v, r, c) (pc.v##_off + (r) * pc.v##_ld + (c))
// Storage buffers are declared with BUF (float), BUFC (float, coherent), IBUF
// (int, read-only), IBUFW (int) and accessed as SB(name)[index]. Two variants
// of every shader are built from the same source:
//  - default: one descriptor binding per buffer; a binding's range is capped
//    by maxStorageBufferRange.
//  - GATCORE_BDA (the "_bda" pipelines): the buffers are reached through 64-bit
//    device addresses (GL_EXT_buffer_reference, as uvec2 so shaderInt64 is not
//    needed) read from an address table at binding GATCORE_ADDR_BINDING, one
//    entry per binding slot, so a tensor or graph array of any size is
//    addressable. The host picks this variant only for dispatches with an
//    operand past the device's binding range. Indices stay 32-bit.
#ifdef GATCORE_BDA
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_buffer_reference_uvec2 : require
#define GATCORE_ADDR_BINDING 10
layout(std430, set = 0, binding = GATCORE_ADDR_BINDING) readonly buffer GatcoreAddr { uvec2 gatcore_addr[]; };
#define GATCORE_REF(binding_, name, qual, T) \
  layout(buffer_reference, std430, buffer_reference_align = 4) qual buffer Ref_##name { T d[]; }; \
  const uint name##_slot = binding_
#define BUF(binding_, name) GATCORE_REF(binding_, name, , ELEM)
#define BUFC(binding_, name) GATCORE_REF(binding_, name, coherent, ELEM)
#define IBUF(binding_, name) GATCORE_REF(binding_, name, readonly, int)
#define IBUFW(binding_, name) GATCORE_REF(binding_, name, , int)
#define SB(name) Ref_##name(gatcore_addr[name##_slot]).d
#else
#define BUF(binding_, name) layout(std430, set = 0, binding = binding_) buffer Buf##binding_ { ELEM name[]; }
#define BUFC(binding_, name) layout(std430, set = 0, binding = binding_) coherent buffer Buf##binding_ { ELEM name[]; }
#define IBUF(binding_, name) layout(std430, set = 0, binding = binding_) readonly buffer IBuf##binding_ { int name[]; }
#define IBUFW(binding_, name) layout(std430, set = 0, binding = binding_) buffer IBuf##binding_ { int name[]; }
#define SB(name) name
#endif
