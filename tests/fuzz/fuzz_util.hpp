#pragma once
// Shared by the fuzz harnesses. A loader may reject an input only with a
// gatcore::Error (a clear message naming the file and the problem); anything
// else -- a crash, a sanitizer report, std::bad_alloc, std::out_of_range from
// a std::sto* call, a hang -- is a defect and ends the run. Loaders that take
// a path get the input through a per-process temp file with the right
// extension.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "gatcore/error.hpp"

namespace gatcore::fuzz {

// The input as a file named "<tmp>/gatcore_fuzz_<pid>/input<ext>"; the same
// path every call (so a harness does no more I/O than one write).
inline std::string as_file(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("gatcore_fuzz_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  const std::string path = (dir / ("input" + ext)).string();
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  os.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  os.close();
  if (!os) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path;
}

template <class F>
int guarded(F&& f) {
  try {
    f();
  } catch (const gatcore::Error&) {
    // rejected with a message: the expected outcome for a bad file
  }
  return 0;
}

}  // namespace gatcore::fuzz
