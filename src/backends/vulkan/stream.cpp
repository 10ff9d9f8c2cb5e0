// Command recording. Ops append dispatches to one current command buffer;
// nothing is submitted until the host needs a result (to_host, a [1, 1] loss
// read) or vulkan::sync() is called, so a whole forward + backward + Adam step
// is one submission. Barriers are inserted only where needed: a dispatch that
// reads or writes a buffer written since the last barrier, or writes a buffer
// read since then, gets one global compute/transfer memory barrier first.
// Descriptor sets come from pools that are reset after each submission.
// A batch is also submitted (and waited for) once it holds kMaxBatch
// dispatches, or once buffers released during it exceed kMaxPendingBytes
// (allocator.cpp), so a long host-read-free loop cannot grow without bound.
//
// Operands larger than a descriptor binding may cover (ctx().max_binding):
// the dispatch runs the shader's _bda variant, which reads each operand's
// device address (buffer address + binding offset) from a small table bound
// at kAddrBinding. Tables are carved from host-visible buffers that live until
// the batch completes; the submission makes the host writes visible.
#include <cstring>
#include <unordered_set>

#include "src/backends/vulkan/runtime.hpp"

namespace gatcore::vk {

namespace {

struct Stream {
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer cb = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  std::vector<VkDescriptorPool> desc_pools;
  std::size_t desc_pool_used = 0;  // index of the pool being allocated from
  bool recording = false;
  std::uint64_t batch_dispatches = 0;
  std::unordered_set<VkBuffer> written, read;
  Buffer* dummy = nullptr;
  VkPipeline bound = VK_NULL_HANDLE;
  // Address tables (host-visible), kept across batches so a warmed-up step
  // allocates nothing: addr_bufs[0..addr_cur] are in use by this batch.
  std::vector<Buffer*> addr_bufs;
  std::size_t addr_cur = 0;
  std::uint64_t addr_used = 0;  // bytes used in addr_bufs[addr_cur]
};
// Never destroyed, like the buffer cache (allocator.cpp): the device is never
// torn down before process exit (tensors in static objects may still release
// buffers then), so the stream's command pool, descriptor pools and address
// tables stay reachable to the end instead of leaking when a static Stream's
// vectors were destroyed under them.
Stream& g_s = *new Stream;
vulkan::Stats g_stats;

constexpr std::uint32_t kSetsPerPool = 1024;
constexpr std::uint64_t kMaxBatch = 8192;

VkDescriptorPool new_desc_pool() {
  VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kSetsPerPool * (kMaxBindings + 1)};
  auto ci = make<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  ci.maxSets = kSetsPerPool;
  ci.poolSizeCount = 1;
  ci.pPoolSizes = &ps;
  VkDescriptorPool p;
  check(vkCreateDescriptorPool(ctx().device, &ci, nullptr, &p), "vkCreateDescriptorPool");
  return p;
}

void begin() {
  if (g_s.recording) return;
  Context& c = ctx();
  if (!g_s.pool) {
    auto ci = make<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    ci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    ci.queueFamilyIndex = c.queue_family;
    check(vkCreateCommandPool(c.device, &ci, nullptr, &g_s.pool), "vkCreateCommandPool");
    auto ai = make<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    ai.commandPool = g_s.pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(c.device, &ai, &g_s.cb), "vkAllocateCommandBuffers");
    auto fi = make<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
    check(vkCreateFence(c.device, &fi, nullptr, &g_s.fence), "vkCreateFence");
    g_s.desc_pools.push_back(new_desc_pool());
    g_s.dummy = acquire_buffer(256);
  }
  auto bi = make<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(g_s.cb, &bi), "vkBeginCommandBuffer");
  g_s.recording = true;
  g_s.bound = VK_NULL_HANDLE;
}

void barrier(VkAccessFlags dst_access, VkPipelineStageFlags dst_stage) {
  auto mb = make<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
  mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_READ_BIT |
                     VK_ACCESS_TRANSFER_READ_BIT;
  mb.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(g_s.cb, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT, dst_stage, 0,
                       1, &mb, 0, nullptr, 0, nullptr);
  ++g_stats.barriers;
  g_s.written.clear();
  g_s.read.clear();
}

// Barrier if this access set conflicts with what was touched since the last one.
void order(const std::vector<std::pair<VkBuffer, bool>>& access) {
  bool need = false;
  for (auto& [buf, w] : access)
    if (g_s.written.count(buf) || (w && g_s.read.count(buf))) need = true;
  if (need)
    barrier(VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                VK_ACCESS_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT);
  for (auto& [buf, w] : access) (w ? g_s.written : g_s.read).insert(buf);
}

VkDescriptorSet alloc_set() {
  VkDescriptorSetLayout layout = set_layout();
  for (;;) {
    auto ai = make<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = g_s.desc_pools[g_s.desc_pool_used];
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &layout;
    VkDescriptorSet set;
    const VkResult r = vkAllocateDescriptorSets(ctx().device, &ai, &set);
    if (r == VK_SUCCESS) return set;
    if (r != VK_ERROR_OUT_OF_POOL_MEMORY && r != VK_ERROR_FRAGMENTED_POOL) check(r, "vkAllocateDescriptorSets");
    if (++g_s.desc_pool_used == g_s.desc_pools.size()) g_s.desc_pools.push_back(new_desc_pool());
  }
}

constexpr std::uint64_t kAddrBufBytes = 64 * 1024;
constexpr std::uint64_t kAddrTableBytes = kMaxBindings * 8;  // one uvec2 per binding slot

// A slot for one dispatch's address table: (buffer, offset) filled with the
// bindings' device addresses; unused slots hold 0 (never dereferenced).
std::pair<Buffer*, std::uint64_t> address_table(const std::vector<Binding>& bindings) {
  const std::uint64_t align = ctx().storage_align;
  const std::uint64_t slot = (kAddrTableBytes + align - 1) / align * align;
  if (g_s.addr_bufs.empty()) g_s.addr_bufs.push_back(acquire_buffer(kAddrBufBytes, true));
  if (g_s.addr_used + slot > g_s.addr_bufs[g_s.addr_cur]->size) {
    if (++g_s.addr_cur == g_s.addr_bufs.size()) g_s.addr_bufs.push_back(acquire_buffer(kAddrBufBytes, true));
    g_s.addr_used = 0;
  }
  Buffer* b = g_s.addr_bufs[g_s.addr_cur];
  const std::uint64_t off = g_s.addr_used;
  g_s.addr_used += slot;
  std::uint64_t table[kMaxBindings] = {};
  for (std::size_t i = 0; i < bindings.size(); ++i)
    if (bindings[i].buffer) table[i] = device_address(bindings[i].owner) + bindings[i].offset;
  std::memcpy(static_cast<char*>(b->mapped) + off, table, kAddrTableBytes);
  return {b, off};
}

}  // namespace

vulkan::Stats& stats_ref() { return g_stats; }
bool has_pending_work() { return g_s.recording; }

void dispatch(const char* shader, const std::vector<Binding>& bindings, const void* push, std::uint32_t push_bytes,
              std::uint32_t gx, std::uint32_t gy, std::uint32_t gz) {
  GATCORE_CHECK(bindings.size() <= kMaxBindings && push_bytes <= kPushBytes, "vulkan: ", shader,
                ": too many bindings / push constants");
  if (gx == 0 || gy == 0 || gz == 0) return;
  if (g_s.batch_dispatches >= kMaxBatch) flush();
  Context& c = ctx();
  GATCORE_CHECK(gx <= c.props.limits.maxComputeWorkGroupCount[0] && gy <= c.props.limits.maxComputeWorkGroupCount[1] &&
                    gz <= c.props.limits.maxComputeWorkGroupCount[2],
                "vulkan: ", shader, ": dispatch of ", gx, "x", gy, "x", gz, " workgroups exceeds the device limit");
  // Any operand past the binding range: the device-address variant.
  const Binding* big = nullptr;
  for (const Binding& b : bindings)
    if (b.buffer && b.range > c.max_binding && (!big || b.range > big->range)) big = &b;
  GATCORE_CHECK(!big || c.bda, "vulkan: ", shader, ": ", big ? big->what : "", " spans ", big ? big->range : 0,
                " bytes, more than the device's binding range (maxStorageBufferRange ", c.max_storage_range,
                ", used ", c.max_binding, "), and ", c.info.name,
                " has no bufferDeviceAddress to reach it otherwise");
  const bool bda = big != nullptr;
  const Pipeline& p = pipeline(shader, bda);
  // Before begin(): acquiring a table buffer may flush the batch.
  const auto table = bda ? address_table(bindings) : std::pair<Buffer*, std::uint64_t>{nullptr, 0};
  begin();
  std::vector<std::pair<VkBuffer, bool>> access;
  for (const Binding& b : bindings)
    if (b.buffer) access.emplace_back(b.buffer, b.write);
  order(access);

  VkDescriptorSet set = alloc_set();
  VkDescriptorBufferInfo infos[kMaxBindings + 1];
  VkWriteDescriptorSet writes[kMaxBindings + 1];
  for (std::uint32_t i = 0; i <= kMaxBindings; ++i) {
    // The _bda variant declares no binding but the table; all others get the dummy.
    const bool real = !bda && i < bindings.size() && bindings[i].buffer;
    infos[i].buffer = real ? bindings[i].buffer : g_s.dummy->buffer;
    infos[i].offset = real ? bindings[i].offset : 0;
    infos[i].range = real ? bindings[i].range : 256;
    if (i == kAddrBinding && bda) {
      infos[i].buffer = table.first->buffer;
      infos[i].offset = table.second;
      infos[i].range = kAddrTableBytes;
    }
    writes[i] = make<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(c.device, kMaxBindings + 1, writes, 0, nullptr);
  if (g_s.bound != p.pipeline) {
    vkCmdBindPipeline(g_s.cb, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
    g_s.bound = p.pipeline;
  }
  vkCmdBindDescriptorSets(g_s.cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_layout(), 0, 1, &set, 0, nullptr);
  if (push_bytes) vkCmdPushConstants(g_s.cb, pipeline_layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes, push);
  vkCmdDispatch(g_s.cb, gx, gy, gz);
  ++g_stats.dispatches;
  if (bda) ++g_stats.bda_dispatches;
  ++g_s.batch_dispatches;
}

void copy_buffer(VkBuffer src, std::uint64_t src_off, VkBuffer dst, std::uint64_t dst_off, std::uint64_t bytes) {
  if (bytes == 0) return;
  begin();
  order({{src, false}, {dst, true}});
  VkBufferCopy region{src_off, dst_off, bytes};
  vkCmdCopyBuffer(g_s.cb, src, dst, 1, &region);
}

void flush() {
  if (!g_s.recording) return;
  Context& c = ctx();
  // Make every write visible to the host reads that follow the wait.
  barrier(VK_ACCESS_HOST_READ_BIT, VK_PIPELINE_STAGE_HOST_BIT);
  check(vkEndCommandBuffer(g_s.cb), "vkEndCommandBuffer");
  g_s.recording = false;
  auto si = make<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
  si.commandBufferCount = 1;
  si.pCommandBuffers = &g_s.cb;
  check(vkQueueSubmit(c.queue, 1, &si, g_s.fence), "vkQueueSubmit");
  ++g_stats.submits;
  VkResult r;
  do r = vkWaitForFences(c.device, 1, &g_s.fence, VK_TRUE, 1'000'000'000ull);
  while (r == VK_TIMEOUT);
  check(r, "vkWaitForFences");
  check(vkResetFences(c.device, 1, &g_s.fence), "vkResetFences");
  check(vkResetCommandPool(c.device, g_s.pool, 0), "vkResetCommandPool");
  for (VkDescriptorPool p : g_s.desc_pools) check(vkResetDescriptorPool(c.device, p, 0), "vkResetDescriptorPool");
  g_s.desc_pool_used = 0;
  g_s.batch_dispatches = 0;
  g_s.written.clear();
  g_s.read.clear();
  g_s.addr_cur = 0;
  g_s.addr_used = 0;
  recycle_pending_buffers();
}

}  // namespace gatcore::vk
