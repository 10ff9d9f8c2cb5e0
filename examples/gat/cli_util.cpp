#include "cli_util.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "gatcore/error.hpp"
#include "gatcore/vulkan.hpp"

namespace gat {

bool is_gltf_path(const std::string& path) {
  std::string p = path;
  std::transform(p.begin(), p.end(), p.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const auto ends = [&](const char* e) {
    const std::string s(e);
    return p.size() > s.size() && p.compare(p.size() - s.size(), s.size(), s) == 0;
  };
  return ends(".glb") || ends(".gltf");
}

gatcore::Device device_from_flag(const std::string& v, const char* command) {
  if (v == "cpu") return gatcore::Device::cpu;
  if (v == "vulkan") return gatcore::vulkan::select("");
  if (v == "auto") return gatcore::vulkan::select("auto");
  throw gatcore::InvalidArgument(std::string(command) + ": --device expects cpu, vulkan or auto, got '" + v + "'");
}

std::string device_label(gatcore::Device d) {
  return d == gatcore::Device::vulkan ? gatcore::vulkan::current_device().name : std::string("cpu");
}

void add_alias(gatcore::character::BoneAliases& aliases, const std::string& spec) {
  const auto eq = spec.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == spec.size())
    throw gatcore::InvalidArgument("--alias expects JOINT=BONE, got '" + spec + "'");
  aliases.pairs.emplace_back(gatcore::character::normalise_bone_name(spec.substr(0, eq)),
                             gatcore::character::normalise_bone_name(spec.substr(eq + 1)));
}

long parse_int(const std::string& flag, const std::string& v, long lo, long hi) {
  char* end = nullptr;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end || x < lo || x > hi)
    throw gatcore::InvalidArgument(flag + " expects an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                   "], got '" + v + "'");
  return x;
}

}  // namespace gat
