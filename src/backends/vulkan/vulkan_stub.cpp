// gatcore::vulkan entry points of a build without the Vulkan backend
// (GATCORE_VULKAN=OFF, or AUTO without Vulkan / glslangValidator).
#ifndef GATCORE_HAS_VULKAN
#include <cstdio>

#include "gatcore/vulkan.hpp"

namespace gatcore::vulkan {

namespace {
[[noreturn]] void not_built() {
  throw Error("vulkan: gatcore was built without the Vulkan backend (configure with -DGATCORE_VULKAN=ON "
              "after installing libvulkan-dev and glslang-tools)");
}
}  // namespace

bool compiled() { return false; }
std::vector<DeviceInfo> list_devices() { return {}; }
void init(const std::string&) { not_built(); }
Device select(const std::string& spec) {
  if (spec == "auto" || spec == "cpu") {
    if (spec == "auto") std::fprintf(stderr, "gatcore: built without Vulkan; running on the CPU (device 'auto')\n");
    return Device::cpu;
  }
  not_built();
}
bool initialised() { return false; }
DeviceInfo current_device() { not_built(); }
void sync() {}
void release_cached_memory() {}
Stats stats() { return {}; }
void forget_graph(const void*) {}

}  // namespace gatcore::vulkan
#endif
