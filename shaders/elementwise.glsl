// Row-major strided 2-D views: element (r, c) of view v is buf[v.off + r*v.ld + c].
// Elementwise shaders run one invocation per element of a [rows, cols] range.
#define VIEW(name) uint name##_off; uint name##_ld
#define AT(v, r, c) (pc.v##_off + (r) * pc.v##_ld + (c))
#define BUF(binding_, name) layout(std430, set = 0, binding = binding_) buffer Buf##binding_ { ELEM name[]; }
#define IBUF(binding_, name) layout(std430, set = 0, binding = binding_) readonly buffer IBuf##binding_ { int name[]; }
