// Checkpoint readers (safetensors header + tensors), from memory: the
// version-2 reader and gat upgrade-checkpoint's (versions 1 and 2, model built).
#include <string_view>

#include "fuzz_util.hpp"
#include "gatcore/models/checkpoint.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gatcore::fuzz::guarded([&] {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    try {
      gatcore::models::parse_checkpoint(bytes, "fuzz.gcm");
    } catch (const gatcore::Error&) {
    }
    // gat upgrade-checkpoint's reader: version 1 too, then the model built from it.
    gatcore::models::upgrade_checkpoint_bytes(bytes, "fuzz.gcm");
  });
}
