// Checkpoint reader (safetensors header + tensors), from memory.
#include <string_view>

#include "fuzz_util.hpp"
#include "gatcore/models/checkpoint.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gatcore::fuzz::guarded([&] {
    gatcore::models::parse_checkpoint(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.gcm");
  });
}
