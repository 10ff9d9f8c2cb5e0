// Dataset description (JSON, with an optional joint-limit table) reader.
#include "fuzz_util.hpp"
#include "gatcore/character/data/dataset.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = gatcore::fuzz::as_file(data, size, ".json");
  return gatcore::fuzz::guarded([&] { gatcore::character::load_dataset(path); });
}
