// BVH reader (gatcore's own; assimp is no longer used for BVH), from memory.
#include <string_view>

#include "fuzz_util.hpp"
#include "gatcore/character/io/bvh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return gatcore::fuzz::guarded([&] {
    gatcore::character::parse_bvh(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.bvh",
                                      [](const std::string&) {});
  });
}
