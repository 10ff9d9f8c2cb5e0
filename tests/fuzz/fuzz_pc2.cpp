// Point cache (.pc2) reader.
#include "fuzz_util.hpp"
#include "gatcore/character/io/bake.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = gatcore::fuzz::as_file(data, size, ".pc2");
  return gatcore::fuzz::guarded([&] { gatcore::character::read_point_cache(path); });
}
