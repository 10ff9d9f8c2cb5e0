// Instance creation, physical-device selection (GPUs first; CPU-type devices
// such as Mesa lavapipe only when named or allowed), logical device and queue,
// and the public gatcore::vulkan entry points.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "gatcore/backend.hpp"
#include "src/backends/vulkan/runtime.hpp"

namespace gatcore::vk {

Backend* backend_instance();  // backend_vulkan.cpp

const char* result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    default: return "VkResult(other)";
  }
}

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw Error(detail::cat("vulkan: ", what, " failed: ", result_name(r), " (", int(r), ")"));
}

namespace {

std::unique_ptr<Context> g_ctx;
std::mutex g_init_mutex;

const char* type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// The instance is created once and kept (listing devices needs one too).
VkInstance shared_instance(bool throw_on_failure) {
  static VkInstance inst = VK_NULL_HANDLE;
  static VkResult status = VK_NOT_READY;
  if (status == VK_NOT_READY) {
    auto app = make<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.pApplicationName = "gatcore";
    app.pEngineName = "gatcore";
    app.apiVersion = VK_API_VERSION_1_1;
    auto ci = make<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    ci.pApplicationInfo = &app;
    status = vkCreateInstance(&ci, nullptr, &inst);
    if (status == VK_NOT_READY) status = VK_ERROR_INITIALIZATION_FAILED;
  }
  if (status != VK_SUCCESS) {
    if (throw_on_failure)
      throw Error(detail::cat("vulkan: no Vulkan instance could be created (", result_name(status),
                              "): is a Vulkan driver installed (mesa-vulkan-drivers for lavapipe)? "
                              "VK_ICD_FILENAMES=", std::getenv("VK_ICD_FILENAMES") ? std::getenv("VK_ICD_FILENAMES") : "(unset)"));
    return VK_NULL_HANDLE;
  }
  return inst;
}

std::vector<VkPhysicalDevice> physical_devices(VkInstance inst) {
  std::uint32_t n = 0;
  if (!inst || vkEnumeratePhysicalDevices(inst, &n, nullptr) != VK_SUCCESS) return {};
  std::vector<VkPhysicalDevice> v(n);
  if (vkEnumeratePhysicalDevices(inst, &n, v.data()) != VK_SUCCESS) return {};
  v.resize(n);
  return v;
}

vulkan::DeviceInfo describe(VkPhysicalDevice pd, int index) {
  auto sg = make<VkPhysicalDeviceSubgroupProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES);
  auto p2 = make<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
  p2.pNext = &sg;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  vulkan::DeviceInfo d{index, p2.properties.deviceName, type_name(p2.properties.deviceType), sg.subgroupSize};
  d.max_storage_buffer_range = p2.properties.limits.maxStorageBufferRange;
  return d;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string device_list_str(const std::vector<vulkan::DeviceInfo>& devs) {
  if (devs.empty()) return "no Vulkan devices found";
  std::string s = "devices:";
  for (const auto& d : devs) s += detail::cat(" [", d.index, "] ", d.name, " (", d.type, ");");
  return s;
}

bool env_flag(const char* name) {
  const char* v = std::getenv(name);
  return v && *v && std::strcmp(v, "0") != 0;
}

// Index of the device `spec` selects, or -1 (with `why`) when none.
int choose(const std::vector<vulkan::DeviceInfo>& devs, std::string spec, std::string& why) {
  if (spec == "auto" || spec == "gpu" || spec == "vulkan") spec.clear();
  if (devs.empty()) {
    why = "no Vulkan devices found (no driver / ICD; on a machine without a GPU install mesa-vulkan-drivers "
          "and select lavapipe with GATCORE_VK_DEVICE=llvmpipe)";
    return -1;
  }
  if (spec.empty()) {
    const bool allow_cpu = env_flag("GATCORE_VK_ALLOW_CPU");
    for (const char* t : {"discrete", "integrated", "virtual", "other", "cpu"})
      for (const auto& d : devs)
        if (d.type == t && (d.type != "cpu" || allow_cpu)) return d.index;
    why = "only CPU-type Vulkan devices found (e.g. Mesa lavapipe); select one explicitly with "
          "GATCORE_VK_DEVICE=<index|name> or set GATCORE_VK_ALLOW_CPU=1; " + device_list_str(devs);
    return -1;
  }
  if (std::all_of(spec.begin(), spec.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    const int i = std::atoi(spec.c_str());
    if (i >= 0 && i < static_cast<int>(devs.size())) return i;
    why = detail::cat("GATCORE_VK_DEVICE / device index ", spec, " is out of range; ", device_list_str(devs));
    return -1;
  }
  for (const auto& d : devs)
    if (lower(d.name).find(lower(spec)) != std::string::npos) return d.index;
  why = detail::cat("no Vulkan device matches '", spec, "'; ", device_list_str(devs));
  return -1;
}

std::string effective_spec(const std::string& spec) {
  if (!spec.empty() && spec != "auto") return spec;
  const char* env = std::getenv("GATCORE_VK_DEVICE");
  if (env && *env) return env;
  return spec;
}

std::unique_ptr<Context> create_context(VkInstance inst, VkPhysicalDevice pd, const vulkan::DeviceInfo& info) {
  auto c = std::make_unique<Context>();
  c->instance = inst;
  c->physical = pd;
  c->info = info;
  auto sg = make<VkPhysicalDeviceSubgroupProperties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES);
  auto m3 = make<VkPhysicalDeviceMaintenance3Properties>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES);
  sg.pNext = &m3;
  auto p2 = make<VkPhysicalDeviceProperties2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
  p2.pNext = &sg;
  vkGetPhysicalDeviceProperties2(pd, &p2);
  c->props = p2.properties;
  const VkSubgroupFeatureFlags need = VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  GATCORE_CHECK((sg.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) && (sg.supportedOperations & need) == need,
                "vulkan: device ", info.name, " lacks subgroup basic/arithmetic operations in compute shaders");
  c->subgroup_size = sg.subgroupSize;
  c->max_storage_range = c->props.limits.maxStorageBufferRange;
  c->max_binding = c->max_storage_range;
  if (const char* cap = std::getenv("GATCORE_VK_MAX_BINDING_BYTES"); cap && *cap) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(cap, &end, 10);
    GATCORE_CHECK(end && *end == 0 && v >= 256, "vulkan: GATCORE_VK_MAX_BINDING_BYTES='", cap,
                  "' must be a byte count >= 256");
    c->max_binding = std::min<std::uint64_t>(c->max_binding, v);
  }
  c->storage_align = std::max<std::uint64_t>(c->props.limits.minStorageBufferOffsetAlignment, 4);
  c->max_allocation = m3.maxMemoryAllocationSize;
  vkGetPhysicalDeviceMemoryProperties(pd, &c->mem_props);
  const bool uma_type = c->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ||
                        c->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;
  bool host_visible_local = false;
  for (std::uint32_t i = 0; i < c->mem_props.memoryTypeCount; ++i) {
    const auto f = c->mem_props.memoryTypes[i].propertyFlags;
    const auto want = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                      VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    if ((f & want) == want) host_visible_local = true;
  }
  // GATCORE_VK_FORCE_STAGING=1 exercises the discrete-GPU path on any device.
  c->unified = uma_type && host_visible_local && !env_flag("GATCORE_VK_FORCE_STAGING");

  std::uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> qf(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(pd, &nq, qf.data());
  std::uint32_t family = nq;
  for (std::uint32_t i = 0; i < nq && family == nq; ++i)
    if (qf[i].queueFlags & VK_QUEUE_COMPUTE_BIT) family = i;
  GATCORE_CHECK(family != nq, "vulkan: device ", info.name, " has no compute queue");
  c->queue_family = family;
  const float prio = 1.0f;
  auto qci = make<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  qci.queueFamilyIndex = family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &prio;
  // Buffer device addresses let shaders reach operands larger than
  // maxStorageBufferRange (the _bda shader variants). The extension form works
  // on Vulkan 1.1 instances too; without it such operands are an error.
  std::uint32_t next = 0;
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &next, nullptr);
  std::vector<VkExtensionProperties> exts(next);
  vkEnumerateDeviceExtensionProperties(pd, nullptr, &next, exts.data());
  bool has_bda_ext = false;
  for (const auto& e : exts)
    if (std::strcmp(e.extensionName, VK_KHR_BUFFER_DEVICE_ADDRESS_EXTENSION_NAME) == 0) has_bda_ext = true;
  auto bda = make<VkPhysicalDeviceBufferDeviceAddressFeaturesKHR>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES_KHR);
  if (has_bda_ext) {
    auto f2 = make<VkPhysicalDeviceFeatures2>(VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2);
    f2.pNext = &bda;
    vkGetPhysicalDeviceFeatures2(pd, &f2);
  }
  c->bda = has_bda_ext && bda.bufferDeviceAddress && !env_flag("GATCORE_VK_NO_BDA");
  auto dci = make<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  const char* bda_ext = VK_KHR_BUFFER_DEVICE_ADDRESS_EXTENSION_NAME;
  auto want = make<VkPhysicalDeviceBufferDeviceAddressFeaturesKHR>(
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES_KHR);
  if (c->bda) {
    want.bufferDeviceAddress = VK_TRUE;
    dci.pNext = &want;
    dci.enabledExtensionCount = 1;
    dci.ppEnabledExtensionNames = &bda_ext;
  }
  check(vkCreateDevice(pd, &dci, nullptr, &c->device), "vkCreateDevice");
  vkGetDeviceQueue(c->device, family, 0, &c->queue);
  if (c->bda) {
    c->get_address = reinterpret_cast<PFN_vkGetBufferDeviceAddressKHR>(
        vkGetDeviceProcAddr(c->device, "vkGetBufferDeviceAddressKHR"));
    c->bda = c->get_address != nullptr;
  }
  c->info.binding_range = c->max_binding;
  c->info.buffer_device_address = c->bda;
  return c;
}

}  // namespace

Context& ctx() {
  if (!g_ctx) throw Error("vulkan: the Vulkan backend is not initialised; call gatcore::vulkan::init()");
  return *g_ctx;
}
bool has_ctx() { return g_ctx != nullptr; }

}  // namespace gatcore::vk

namespace gatcore::vulkan {

bool compiled() { return true; }

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  const auto pds = vk::physical_devices(vk::shared_instance(false));
  for (std::size_t i = 0; i < pds.size(); ++i) out.push_back(vk::describe(pds[i], static_cast<int>(i)));
  return out;
}

void init(const std::string& spec_in) {
  std::lock_guard lock(vk::g_init_mutex);
  const std::string spec = vk::effective_spec(spec_in);
  VkInstance inst = vk::shared_instance(true);
  const auto pds = vk::physical_devices(inst);
  std::vector<DeviceInfo> devs;
  for (std::size_t i = 0; i < pds.size(); ++i) devs.push_back(vk::describe(pds[i], static_cast<int>(i)));
  std::string why;
  const int idx = vk::choose(devs, spec, why);
  if (idx < 0) throw Error("vulkan: " + why);
  if (vk::g_ctx) {
    GATCORE_CHECK(vk::g_ctx->physical == pds[idx], "vulkan: already initialised on device '", vk::g_ctx->info.name,
                  "'; cannot switch to '", devs[idx].name, "' in the same process");
    return;
  }
  vk::g_ctx = vk::create_context(inst, pds[idx], devs[idx]);
  register_backend(vk::backend_instance());
}

Device select(const std::string& spec) {
  const std::string s = vk::effective_spec(spec);
  if (s == "cpu") return Device::cpu;
  try {
    init(s);
    return Device::vulkan;
  } catch (const Error& e) {
    if (spec != "auto" || (s != "auto" && !s.empty())) throw;
    std::fprintf(stderr, "gatcore: %s; running on the CPU (device 'auto')\n", e.what());
    return Device::cpu;
  }
}

bool initialised() { return vk::has_ctx(); }
DeviceInfo current_device() { return vk::ctx().info; }

void sync() {
  if (vk::has_ctx()) vk::flush();
}

void release_cached_memory() {
  if (!vk::has_ctx()) return;
  vk::flush();
  vk::free_cached_buffers();
}

Stats stats() {
  if (!vk::has_ctx()) return {};
  Stats s = vk::stats_ref();
  s.cached_bytes = vk::cached_bytes();
  return s;
}

void forget_graph(const void* graph) {
  if (vk::has_ctx()) vk::forget_graph(graph);
}

}  // namespace gatcore::vulkan
