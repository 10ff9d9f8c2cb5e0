// Buffers and the caching allocator. Every tensor storage is one VkBuffer with
// its own VkDeviceMemory, sized to a size class (4 classes per power of two).
// Released buffers go to a pending list and become reusable when the commands
// recorded before the release have completed (the next flush), so a host write
// into a freshly acquired buffer can never race with queued GPU work, and a
// training step allocates nothing once a first step has warmed the cache.
#include <algorithm>
#include <cstring>
#include <map>

#include "src/backends/vulkan/runtime.hpp"

namespace gatcore::vk {

namespace {

struct Cache {
  std::multimap<std::uint64_t, Buffer*> free_device, free_staging;
  std::vector<Buffer*> pending;
  std::uint64_t pending_bytes = 0;
  std::uint64_t cached = 0;
};
// Never destroyed: tensors in static objects may release buffers during
// process exit, after any static cache would be gone.
Cache& g_cache = *new Cache;

std::uint64_t size_class(std::uint64_t bytes) {
  if (bytes <= 256) return 256;
  std::uint64_t p = 256;
  while (p * 2 < bytes) p *= 2;  // p < bytes <= 2p
  for (int q = 1; q <= 4; ++q) {
    const std::uint64_t s = p + p * q / 4;
    if (s >= bytes) return s;
  }
  return 2 * p;
}

int memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags want, VkMemoryPropertyFlags prefer) {
  const auto& mp = ctx().mem_props;
  int fallback = -1;
  for (std::uint32_t i = 0; i < mp.memoryTypeCount; ++i) {
    if (!(type_bits & (1u << i))) continue;
    const auto f = mp.memoryTypes[i].propertyFlags;
    if ((f & want) != want) continue;
    if ((f & prefer) == prefer) return static_cast<int>(i);
    if (fallback < 0) fallback = static_cast<int>(i);
  }
  return fallback;
}

void destroy(Buffer* b) {
  Context& c = ctx();
  if (b->mapped) vkUnmapMemory(c.device, b->memory);
  vkDestroyBuffer(c.device, b->buffer, nullptr);
  vkFreeMemory(c.device, b->memory, nullptr);
  delete b;
}

[[noreturn]] void out_of_memory(std::uint64_t bytes, const char* why) {
  Context& c = ctx();
  std::uint64_t heap = 0;
  for (std::uint32_t i = 0; i < c.mem_props.memoryHeapCount; ++i)
    heap = std::max<std::uint64_t>(heap, c.mem_props.memoryHeaps[i].size);
  throw Error(detail::cat("vulkan: out of device memory allocating ", bytes, " bytes on ", c.info.name, " (",
                          why, "; largest heap ", heap, " bytes, max allocation ", c.max_allocation,
                          " bytes, cache ", g_cache.cached, " bytes)"));
}

Buffer* create(std::uint64_t size, bool staging) {
  Context& c = ctx();
  if (c.max_allocation && size > c.max_allocation) out_of_memory(size, "larger than maxMemoryAllocationSize");
  auto b = std::make_unique<Buffer>();
  b->size = size;
  auto bi = make<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
  bi.size = size;
  bi.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  if (c.bda) bi.usage |= VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT_KHR;  // any buffer may be a _bda operand
  bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  VkResult r = vkCreateBuffer(c.device, &bi, nullptr, &b->buffer);
  if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) out_of_memory(size, result_name(r));
  check(r, "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(c.device, b->buffer, &req);
  const bool host = staging || c.unified;
  const VkMemoryPropertyFlags host_bits = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  int type = staging   ? memory_type(req.memoryTypeBits, host_bits, VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
             : host    ? memory_type(req.memoryTypeBits, host_bits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)
                       : memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0);
  if (type < 0) {
    vkDestroyBuffer(c.device, b->buffer, nullptr);
    throw Error("vulkan: no suitable memory type for a storage buffer");
  }
  auto ai = make<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  ai.allocationSize = req.size;
  ai.memoryTypeIndex = static_cast<std::uint32_t>(type);
  auto flags = make<VkMemoryAllocateFlagsInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO);
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT_KHR;
  if (c.bda) ai.pNext = &flags;
  r = vkAllocateMemory(c.device, &ai, nullptr, &b->memory);
  if (r != VK_SUCCESS) {
    vkDestroyBuffer(c.device, b->buffer, nullptr);
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) return nullptr;
    check(r, "vkAllocateMemory");
  }
  ++stats_ref().device_allocations;
  check(vkBindBufferMemory(c.device, b->buffer, b->memory, 0), "vkBindBufferMemory");
  if (host) {
    check(vkMapMemory(c.device, b->memory, 0, VK_WHOLE_SIZE, 0, &b->mapped), "vkMapMemory");
    b->host_visible = true;
  }
  return b.release();
}

void release_storage(Storage& s) {
  if (s.handle) release_buffer(static_cast<Buffer*>(s.handle));
  s.handle = nullptr;
}

}  // namespace

Buffer* acquire_buffer(std::uint64_t bytes, bool staging) {
  const std::uint64_t size = size_class(bytes);
  // Buffers released during a long batch only come back after it completes:
  // past 1 GiB of them, complete it now and reuse them.
  if (g_cache.pending_bytes > (std::uint64_t{1} << 30)) flush();
  auto& fl = staging ? g_cache.free_staging : g_cache.free_device;
  // Reuse a cached buffer of this class (or one class up, at most 2x).
  auto it = fl.lower_bound(size);
  if (it != fl.end() && it->first <= 2 * size) {
    Buffer* b = it->second;
    fl.erase(it);
    g_cache.cached -= b->size;
    return b;
  }
  Buffer* b = create(size, staging);
  if (!b) {
    // Out of memory: give the cache back to the driver and try once more.
    flush();
    free_cached_buffers();
    b = create(size, staging);
    if (!b) out_of_memory(bytes, "vkAllocateMemory: VK_ERROR_OUT_OF_DEVICE_MEMORY");
  }
  return b;
}

void release_buffer(Buffer* b) {
  if (!b || !has_ctx()) return;  // process teardown: the device outlives the tensors
  if (has_pending_work()) {
    g_cache.pending.push_back(b);
    g_cache.pending_bytes += b->size;
  } else {
    (b->host_visible && !ctx().unified ? g_cache.free_staging : g_cache.free_device).emplace(b->size, b);
    g_cache.cached += b->size;
  }
}

void recycle_pending_buffers() {
  for (Buffer* b : g_cache.pending) {
    (b->host_visible && !ctx().unified ? g_cache.free_staging : g_cache.free_device).emplace(b->size, b);
    g_cache.cached += b->size;
  }
  g_cache.pending.clear();
  g_cache.pending_bytes = 0;
}

void free_cached_buffers() {
  for (auto* fl : {&g_cache.free_device, &g_cache.free_staging}) {
    for (auto& [size, b] : *fl) destroy(b);
    fl->clear();
  }
  g_cache.cached = 0;
}

void destroy_all_buffers() {
  recycle_pending_buffers();
  free_cached_buffers();
}

std::uint64_t cached_bytes() { return g_cache.cached; }

std::uint64_t device_address(Buffer* b) {
  if (!b->address) {
    Context& c = ctx();
    auto info = make<VkBufferDeviceAddressInfoKHR>(VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO_KHR);
    info.buffer = b->buffer;
    b->address = c.get_address(c.device, &info);
  }
  return b->address;
}

std::shared_ptr<Storage> make_storage(std::uint64_t bytes) {
  auto s = std::make_shared<Storage>();
  Buffer* b = acquire_buffer(bytes);
  s->handle = b;
  s->bytes = bytes;
  s->device = Device::vulkan;
  s->host = nullptr;  // never host-addressable: reads go through to_host (which syncs)
  s->release = release_storage;
  return s;
}

}  // namespace gatcore::vk

namespace gatcore::vk {

std::shared_ptr<Storage> upload(const void* data, std::uint64_t bytes) {
  auto s = make_storage(bytes);
  if (bytes == 0) return s;
  Buffer* b = buffer_of(*s);
  if (b->mapped) {
    // A fresh (or recycled after completion) buffer: no queued command uses it.
    std::memcpy(b->mapped, data, bytes);
  } else {
    Buffer* st = acquire_buffer(bytes, true);
    std::memcpy(st->mapped, data, bytes);
    copy_buffer(st->buffer, 0, b->buffer, 0, bytes);
    release_buffer(st);
  }
  return s;
}

void download(const Storage& s, std::uint64_t offset, std::uint64_t bytes, void* out) {
  Buffer* b = buffer_of(s);
  if (bytes == 0) return;
  if (b->mapped) {
    flush();
    std::memcpy(out, static_cast<const char*>(b->mapped) + offset, bytes);
  } else {
    Buffer* st = acquire_buffer(bytes, true);
    copy_buffer(b->buffer, offset, st->buffer, 0, bytes);
    flush();
    std::memcpy(out, st->mapped, bytes);
    release_buffer(st);
  }
}

}  // namespace gatcore::vk
