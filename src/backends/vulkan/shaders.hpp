#pragma once
// The SPIR-V of shaders/*.comp, embedded at build time (shaders_embedded.cpp.in).
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace gatcore::vk {

struct ShaderBlob {
  const char* name;        // shaders/<name>.comp
  const std::uint32_t* code;
  std::size_t words;
};

// nullptr when no shader of that name was compiled in.
const ShaderBlob* find_shader(std::string_view name);

}  // namespace gatcore::vk
