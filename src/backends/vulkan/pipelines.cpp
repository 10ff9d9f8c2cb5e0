// Compute pipelines, created on first use from the embedded SPIR-V and cached
// by shader name (the _bda variant under "<name>_bda"). All pipelines share one
// layout: kMaxBindings storage buffers plus the device-address table
// (kAddrBinding) in set 0 and a kPushBytes push-constant block. Specialisation constants:
//   constant_id 0  SUBGROUP_SIZE  (the device's subgroup size; lavapipe: 4/8/16
//                                  with LP_NATIVE_VECTOR_WIDTH 128/256/512)
//   constant_id 1  local_size_x   (workgroup size, a multiple of SUBGROUP_SIZE)
#include <algorithm>
#include <string>

#include "src/backends/vulkan/runtime.hpp"
#include "src/backends/vulkan/shaders.hpp"

namespace gatcore::vk {

namespace {

struct Pipelines {
  VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipelineCache cache = VK_NULL_HANDLE;
  std::unordered_map<std::string, Pipeline> by_name;
};
Pipelines g_p;

void ensure_layout() {
  if (g_p.layout) return;
  Context& c = ctx();
  VkDescriptorSetLayoutBinding b[kMaxBindings + 1]{};
  for (std::uint32_t i = 0; i <= kMaxBindings; ++i) {
    b[i].binding = i;
    b[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  auto sci = make<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  sci.bindingCount = kMaxBindings + 1;
  sci.pBindings = b;
  check(vkCreateDescriptorSetLayout(c.device, &sci, nullptr, &g_p.set_layout), "vkCreateDescriptorSetLayout");
  VkPushConstantRange pr{VK_SHADER_STAGE_COMPUTE_BIT, 0, kPushBytes};
  auto lci = make<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  lci.setLayoutCount = 1;
  lci.pSetLayouts = &g_p.set_layout;
  lci.pushConstantRangeCount = 1;
  lci.pPushConstantRanges = &pr;
  check(vkCreatePipelineLayout(c.device, &lci, nullptr, &g_p.layout), "vkCreatePipelineLayout");
  auto cci = make<VkPipelineCacheCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO);
  check(vkCreatePipelineCache(c.device, &cci, nullptr, &g_p.cache), "vkCreatePipelineCache");
}

}  // namespace

VkPipelineLayout pipeline_layout() {
  ensure_layout();
  return g_p.layout;
}
VkDescriptorSetLayout set_layout() {
  ensure_layout();
  return g_p.set_layout;
}

const Pipeline& pipeline(const char* shader, bool bda) {
  const std::string name = bda ? std::string(shader) + "_bda" : std::string(shader);
  auto it = g_p.by_name.find(name);
  if (it != g_p.by_name.end()) return it->second;
  ensure_layout();
  Context& c = ctx();
  const ShaderBlob* blob = find_shader(name);
  GATCORE_CHECK(blob != nullptr, "vulkan: shader '", name, "' is not compiled into this build");
  auto mci = make<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  mci.codeSize = blob->words * 4;
  mci.pCode = blob->code;
  VkShaderModule module;
  check(vkCreateShaderModule(c.device, &mci, nullptr, &module), "vkCreateShaderModule");

  Pipeline p;
  const std::uint32_t sg = c.subgroup_size;
  p.wg_size = std::max<std::uint32_t>(sg, std::min<std::uint32_t>(256, c.props.limits.maxComputeWorkGroupSize[0]) / sg * sg);
  const std::uint32_t spec_data[2] = {sg, p.wg_size};
  const VkSpecializationMapEntry entries[2] = {{0, 0, 4}, {1, 4, 4}};
  VkSpecializationInfo spec{2, entries, sizeof spec_data, spec_data};
  auto ci = make<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = module;
  ci.stage.pName = "main";
  ci.stage.pSpecializationInfo = &spec;
  ci.layout = g_p.layout;
  const VkResult r = vkCreateComputePipelines(c.device, g_p.cache, 1, &ci, nullptr, &p.pipeline);
  vkDestroyShaderModule(c.device, module, nullptr);
  check(r, "vkCreateComputePipelines");
  return g_p.by_name.emplace(name, p).first->second;
}

void destroy_pipelines() {
  if (!has_ctx()) return;
  Context& c = ctx();
  for (auto& [name, p] : g_p.by_name) vkDestroyPipeline(c.device, p.pipeline, nullptr);
  g_p.by_name.clear();
  if (g_p.cache) vkDestroyPipelineCache(c.device, g_p.cache, nullptr);
  if (g_p.layout) vkDestroyPipelineLayout(c.device, g_p.layout, nullptr);
  if (g_p.set_layout) vkDestroyDescriptorSetLayout(c.device, g_p.set_layout, nullptr);
  g_p = Pipelines{};
}

}  // namespace gatcore::vk
