// glTF character import (tinygltf + gatcore's checks): binary when the input
// starts with the GLB magic, JSON otherwise. External URIs can only reach
// files in the per-process temp folder (the confinement under test too).
#include <cstring>

#include "fuzz_util.hpp"
#include "gatcore/character/io/gltf.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const std::string path = gatcore::fuzz::as_file(data, size, glb ? ".glb" : ".gltf");
  return gatcore::fuzz::guarded([&] { gatcore::character::load_gltf(path); });
}
