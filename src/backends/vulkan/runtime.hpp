#pragma once
// Internal Vulkan runtime of the backend: one concept per .cpp
//   context.cpp    instance, device selection, queue, limits
//   allocator.cpp  buffers and the caching allocator
//   pipelines.cpp  shader modules / compute pipelines (one cache)
//   stream.cpp     command recording, barriers, batching, submission
//   graphs.cpp     device copies of CsrGraphs
//   backend_vulkan.cpp  the Backend implementation
#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <vector>

#include "gatcore/error.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"
#include "gatcore/vulkan.hpp"

namespace gatcore::vk {

// A zeroed Vulkan create-info / properties struct with its sType set.
template <class T>
T make(VkStructureType type) {
  T t{};
  t.sType = type;
  return t;
}

// Throws gatcore::Error naming the call and the VkResult.
void check(VkResult r, const char* what);
const char* result_name(VkResult r);

// ---- context.cpp -------------------------------------------------------------
struct Context {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t queue_family = 0;
  vulkan::DeviceInfo info{};
  VkPhysicalDeviceProperties props{};
  VkPhysicalDeviceMemoryProperties mem_props{};
  std::uint32_t subgroup_size = 32;
  std::uint64_t max_storage_range = 0;   // maxStorageBufferRange
  // The largest range a descriptor binding is given: maxStorageBufferRange,
  // or less when GATCORE_VK_MAX_BINDING_BYTES caps it (a test hook that sends
  // small tensors through the large-buffer paths). Operands past it are
  // chunked (elementwise ops) or reached by device address (the _bda shaders).
  std::uint64_t max_binding = 0;
  // bufferDeviceAddress (VK_KHR_buffer_device_address) is enabled; off when
  // the device lacks it or GATCORE_VK_NO_BDA=1 is set.
  bool bda = false;
  PFN_vkGetBufferDeviceAddressKHR get_address = nullptr;
  std::uint64_t storage_align = 16;      // minStorageBufferOffsetAlignment
  std::uint64_t max_allocation = 0;      // maxMemoryAllocationSize (or heap size)
  bool unified = false;                  // buffers are host-visible (CPU / UMA device)
};
// The initialised context (throws when vulkan::init has not succeeded).
Context& ctx();
bool has_ctx();

// ---- allocator.cpp -------------------------------------------------------------
struct Buffer {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  std::uint64_t size = 0;    // allocated bytes (size class)
  void* mapped = nullptr;    // persistent map when host-visible
  bool host_visible = false;
  std::uint64_t address = 0;  // device address (when ctx().bda), 0 until first asked
};
// A buffer of at least `bytes` (reused from the cache when possible). Throws
// gatcore::Error("vulkan: out of device memory ...") when it cannot be had.
Buffer* acquire_buffer(std::uint64_t bytes, bool host_visible_staging = false);
// Returns a buffer to the cache; it becomes reusable once the commands
// recorded so far have completed (after the next submission finishes).
void release_buffer(Buffer* b);
// Called by the stream after a submission completed.
void recycle_pending_buffers();
void free_cached_buffers();
void destroy_all_buffers();
std::uint64_t cached_bytes();
// The buffer's device address (requires ctx().bda).
std::uint64_t device_address(Buffer* b);

// A Storage (Device::vulkan, host == nullptr) that owns a Buffer.
std::shared_ptr<Storage> make_storage(std::uint64_t bytes);
inline Buffer* buffer_of(const Storage& s) { return static_cast<Buffer*>(s.handle); }
// Host -> device: a new storage holding `bytes` bytes of `data` (memcpy into a
// host-visible buffer, or a staging copy recorded into the current stream).
std::shared_ptr<Storage> upload(const void* data, std::uint64_t bytes);
// Device -> host: `bytes` bytes at byte offset `offset` of `s` (flushes first).
void download(const Storage& s, std::uint64_t offset, std::uint64_t bytes, void* out);

// ---- pipelines.cpp -------------------------------------------------------------
constexpr std::uint32_t kMaxBindings = 10;
// One more binding in the shared layout: the device-address table the _bda
// shader variants read (GATCORE_ADDR_BINDING in shaders/elementwise.glsl).
constexpr std::uint32_t kAddrBinding = kMaxBindings;
constexpr std::uint32_t kPushBytes = 128;
struct Pipeline {
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::uint32_t wg_size = 256;  // local_size_x (specialisation constant 1)
};
// `bda`: the device-address variant (shaders/<name>.comp built with -DGATCORE_BDA).
const Pipeline& pipeline(const char* shader, bool bda = false);
VkPipelineLayout pipeline_layout();
VkDescriptorSetLayout set_layout();
void destroy_pipelines();

// ---- stream.cpp ----------------------------------------------------------------
// One bound buffer range: a tensor's storage at an (aligned) byte offset.
struct Binding {
  VkBuffer buffer = VK_NULL_HANDLE;
  std::uint64_t offset = 0;
  std::uint64_t range = 0;
  bool write = false;
  const char* what = "operand";  // for errors
  Buffer* owner = nullptr;       // for its device address
};
// Records one dispatch into the current command buffer, with a barrier first
// when it touches a buffer written (or writes one read) since the last barrier.
// When a binding's range exceeds ctx().max_binding the shader's _bda variant
// runs instead, its buffers addressed through a table of device addresses
// (throws, naming the shader and operand, when the device has no
// bufferDeviceAddress).
void dispatch(const char* shader, const std::vector<Binding>& bindings, const void* push, std::uint32_t push_bytes,
              std::uint32_t groups_x, std::uint32_t groups_y = 1, std::uint32_t groups_z = 1);
// Records a buffer copy (transfer) with the barriers it needs.
void copy_buffer(VkBuffer src, std::uint64_t src_off, VkBuffer dst, std::uint64_t dst_off, std::uint64_t bytes);
// Submits what was recorded and waits; recycles released buffers.
void flush();
bool has_pending_work();
vulkan::Stats& stats_ref();

// ---- graphs.cpp ----------------------------------------------------------------
// Device copy of a CsrGraph's arrays as int32: indptr, indices, out_ptr,
// out_dst, out_edge (one buffer each).
struct DeviceGraph {
  std::shared_ptr<Storage> indptr, indices, out_ptr, out_dst, out_edge;
  std::int64_t num_nodes = 0, num_edges = 0;
};
const DeviceGraph& device_graph(const CsrGraph& g);
void forget_graph(const void* g);
void clear_graphs();

}  // namespace gatcore::vk
