// main() for the fuzz harnesses when libFuzzer is not available (GCC builds):
// runs LLVMFuzzerTestOneInput once on every file named on the command line
// (directories: every file in them), like `fuzzer FILE...` does with libFuzzer.
// A harness reports a defect by crashing or by letting a non-gatcore
// exception escape; either ends this process with a non-zero status.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const fs::path p = argv[i];
    if (!p.empty() && p.string()[0] == '-') continue;  // libFuzzer flags (-runs=0 ...)
    if (fs::is_directory(p)) {
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file()) files.push_back(e.path());
    } else {
      files.push_back(p);
    }
  }
  for (const auto& f : files) {
    std::ifstream is(f, std::ios::binary);
    if (!is) {
      std::fprintf(stderr, "replay: cannot read %s\n", f.c_str());
      return 2;
    }
    const std::string bytes{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replay: %zu inputs, no defect\n", files.size());
  return 0;
}
