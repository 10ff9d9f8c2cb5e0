// ASF / AMC reader, from memory. An input is an ASF skeleton, optionally
// followed by a line "---amc---" and an AMC motion for it.
#include <string_view>

#include "fuzz_util.hpp"
#include "gatcore/character/io/asf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const std::size_t cut = all.find("\n---amc---\n");
  return gatcore::fuzz::guarded([&] {
    if (cut == std::string_view::npos) {
      gatcore::character::parse_asf(all, "fuzz.asf");
      return;
    }
    gatcore::character::parse_asf_amc(all.substr(0, cut), "fuzz.asf", all.substr(cut + 11), "fuzz.amc", 0.0f,
                                      [](const std::string&) {});
  });
}
