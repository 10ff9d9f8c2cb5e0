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
#include <unordered_set>

#include "src/vulkan/runtime.hpp"

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
};
Stream g_s;
vulkan::Stats g_stats;

constexpr std::uint32_t kSetsPerPool = 1024;
constexpr std::uint64_t kMaxBatch = 8192;

VkDescriptorPool new_desc_pool() {
  VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kSetsPerPool * kMaxBindings};
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
  const Pipeline& p = pipeline(shader);
  begin();
  std::vector<std::pair<VkBuffer, bool>> access;
  for (const Binding& b : bindings)
    if (b.buffer) access.emplace_back(b.buffer, b.write);
  order(access);

  VkDescriptorSet set = alloc_set();
  VkDescriptorBufferInfo infos[kMaxBindings];
  VkWriteDescriptorSet writes[kMaxBindings];
  for (std::uint32_t i = 0; i < kMaxBindings; ++i) {
    const bool real = i < bindings.size() && bindings[i].buffer;
    infos[i].buffer = real ? bindings[i].buffer : g_s.dummy->buffer;
    infos[i].offset = real ? bindings[i].offset : 0;
    infos[i].range = real ? bindings[i].range : 256;
    writes[i] = make<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  vkUpdateDescriptorSets(c.device, kMaxBindings, writes, 0, nullptr);
  if (g_s.bound != p.pipeline) {
    vkCmdBindPipeline(g_s.cb, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
    g_s.bound = p.pipeline;
  }
  vkCmdBindDescriptorSets(g_s.cb, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_layout(), 0, 1, &set, 0, nullptr);
  if (push_bytes) vkCmdPushConstants(g_s.cb, pipeline_layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, push_bytes, push);
  vkCmdDispatch(g_s.cb, gx, gy, gz);
  ++g_stats.dispatches;
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
  recycle_pending_buffers();
}

void destroy_stream() {
  if (!has_ctx()) return;
  flush();
  Context& c = ctx();
  for (VkDescriptorPool p : g_s.desc_pools) vkDestroyDescriptorPool(c.device, p, nullptr);
  if (g_s.fence) vkDestroyFence(c.device, g_s.fence, nullptr);
  if (g_s.pool) vkDestroyCommandPool(c.device, g_s.pool, nullptr);
  g_s = Stream{};
}

}  // namespace gatcore::vk
