// The Catch2 main of every test executable.
//
// ctest runs each test case as a process of its own, two or more at a time
// (CI: -j2), and tests write scratch files under temp_directory_path() with
// fixed names: two test cases of test_character_motion both write and read
// "self.bvh", and one read the other's half-written file ("the file ends
// where HIERARCHY was expected"). So each process gets a scratch folder of
// its own as TMPDIR (what temp_directory_path() and child processes use),
// removed when the process ends.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

int main(int argc, char** argv) {
  const char* base = std::getenv("TMPDIR");
  std::string pattern = std::string(base && *base ? base : "/tmp") + "/gatcore_test_XXXXXX";
  std::vector<char> buf(pattern.begin(), pattern.end());
  buf.push_back('\0');
  const char* dir = mkdtemp(buf.data());
  if (dir) setenv("TMPDIR", dir, 1);  // without one (read-only /tmp), the shared folder as before
  const int rc = Catch::Session().run(argc, argv);
  if (dir) {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
  return rc;
}
