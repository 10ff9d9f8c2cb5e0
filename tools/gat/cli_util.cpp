#include "cli_util.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>

#include "cli_options.hpp"
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
  std::string text = v;
  const std::string err = int_in(lo, hi)(text);  // the options' own check and wording
  if (!err.empty()) throw gatcore::InvalidArgument(flag + ": " + err);
  return std::strtol(v.c_str(), nullptr, 10);
}

void warn_absent_bones(const char* command, const std::string& warning, const char* remedy) {
  if (!warning.empty())
    std::fprintf(stderr, "%s: %s. Name the matching joints with --alias JOINT=BONE, or %s.\n", command, warning.c_str(),
                 remedy);
}

}  // namespace gat
