#pragma once
// The Vulkan compute backend: device selection and synchronisation.
//
// gatcore registers the Vulkan backend (Device::vulkan) when init() succeeds;
// from then on tensors moved with to(t, Device::vulkan) run every op on the
// GPU. Ops are recorded into a command buffer and submitted only when the host
// needs data (to_host / to(t, Device::cpu), reading a [1, 1] loss) or on sync().
//
// Device selection (`spec`, or the GATCORE_VK_DEVICE environment variable when
// spec is empty):
//   ""/"gpu"   the first discrete, then integrated/virtual GPU; CPU-type
//              devices (Mesa lavapipe) are NOT chosen unless named or
//              GATCORE_VK_ALLOW_CPU=1 is set;
//   "<index>"  the device of that index in list_devices() (any type);
//   "<text>"   the first device whose name contains <text> (case-insensitive),
//              e.g. "llvmpipe" for lavapipe;
//   "auto"     like "gpu", but when no suitable device exists select() returns
//              Device::cpu instead of throwing (and says so on stderr).
// Errors are gatcore::Error with the list of devices found.
#include <string>
#include <vector>

#include "gatcore/tensor.hpp"

namespace gatcore::vulkan {

// Whether this build of gatcore contains the Vulkan backend.
bool compiled();

struct DeviceInfo {
  int index;
  std::string name;
  std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
  std::uint32_t subgroup_size;
  std::uint64_t max_storage_buffer_range = 0;  // the device's maxStorageBufferRange
  // Set once the backend runs on the device (current_device()): the range a
  // descriptor binding is given (maxStorageBufferRange, or less under the test
  // hook GATCORE_VK_MAX_BINDING_BYTES) and whether bufferDeviceAddress is on.
  // Operands past binding_range are chunked (elementwise ops) or reached by
  // device address (every other op); without bufferDeviceAddress the latter
  // throw an error naming the op and operand.
  std::uint64_t binding_range = 0;
  bool buffer_device_address = false;
};
// Devices the Vulkan loader reports (empty when no loader/driver/ICD).
std::vector<DeviceInfo> list_devices();

// Initialises the backend on the device `spec` selects and registers it.
// Idempotent for the same device; throws when already initialised on another.
void init(const std::string& spec = "");
// init(spec) and Device::vulkan, or Device::cpu when spec is "auto" and no
// usable device exists.
Device select(const std::string& spec = "auto");
bool initialised();
// The selected device's name / info (throws when not initialised).
DeviceInfo current_device();

// Submits the recorded commands and waits for them.
void sync();
// Frees every cached (unused) buffer after a sync.
void release_cached_memory();

struct Stats {
  std::uint64_t submits = 0;          // queue submissions so far
  std::uint64_t dispatches = 0;       // compute dispatches recorded so far
  // Of those, for operands past the device's binding range: through device
  // addresses (_bda shaders), and parts of an elementwise op split into row chunks.
  std::uint64_t bda_dispatches = 0;
  std::uint64_t chunked_dispatches = 0;
  std::uint64_t barriers = 0;         // pipeline barriers recorded so far
  std::uint64_t device_allocations = 0;  // vkAllocateMemory calls (cache misses)
  std::uint64_t cached_bytes = 0;     // bytes held by free buffers in the cache
  std::uint64_t graph_uploads = 0;    // CsrGraphs uploaded (cache misses)
};
Stats stats();

// Drops the device copy of a graph (see the graph-cache rule in docs/library.md: graphs
// are cached by address, node/edge counts and a content fingerprint; forget a
// graph before mutating it in place and reusing it at the same address).
void forget_graph(const void* graph);

}  // namespace gatcore::vulkan
