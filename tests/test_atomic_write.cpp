// Every writer goes through write_file_atomic: on a full disk (simulated with
// RLIMIT_FSIZE, which makes write() fail with EFBIG past the limit) the
// writer throws naming the file, the old contents stay, and no temp file is
// left; a stale temp file from a killed earlier write is cleaned.
#include <catch2/catch.hpp>

#include <dlfcn.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gatcore/atomic_file.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
using Catch::Matchers::Contains;
namespace fs = std::filesystem;

// fsync and rename as gatcore calls them (libgatcore is linked statically into
// this executable, so these definitions are the ones it calls): recorded while
// `g_calls` is set, then passed on to the C library's.
namespace {
std::vector<std::string>* g_calls = nullptr;
}  // namespace

extern "C" int fsync(int fd) {
  static const auto real = reinterpret_cast<int (*)(int)>(dlsym(RTLD_NEXT, "fsync"));
  if (g_calls) {
    char target[4096] = {};
    const ::ssize_t n = ::readlink(("/proc/self/fd/" + std::to_string(fd)).c_str(), target, sizeof target - 1);
    g_calls->push_back("fsync " + std::string(target, n > 0 ? std::size_t(n) : 0));
  }
  return real(fd);
}

extern "C" int rename(const char* from, const char* to) noexcept {
  static const auto real = reinterpret_cast<int (*)(const char*, const char*)>(dlsym(RTLD_NEXT, "rename"));
  if (g_calls) g_calls->push_back(std::string("rename ") + from + " -> " + to);
  return real(from, to);
}

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream is(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
}

// Files may grow to `bytes` while alive (SIGXFSZ ignored: write() fails instead).
struct DiskFull {
  rlimit old{};
  void (*old_handler)(int);
  explicit DiskFull(rlim_t bytes) {
    getrlimit(RLIMIT_FSIZE, &old);
    old_handler = std::signal(SIGXFSZ, SIG_IGN);
    rlimit lim = old;
    lim.rlim_cur = bytes;
    REQUIRE(setrlimit(RLIMIT_FSIZE, &lim) == 0);
  }
  ~DiskFull() {
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
};

template <class Write>
void check_full_disk(const fs::path& path, Write write) {
  INFO(path.string());
  std::ofstream(path, std::ios::binary) << "old contents";
  // The OpenMP runtime starts before the file-size limit: LLVM's libomp (the
  // clang sanitizer build) writes a shared-memory file when it starts, which
  // the limit would make fail inside the runtime.
#pragma omp parallel
  { [[maybe_unused]] volatile int started = 1; }
  {
    DiskFull full(64);
    CHECK_THROWS_WITH(write(), Contains(path.string()));
  }
  CHECK(slurp(path) == "old contents");
  CHECK_FALSE(fs::exists(path.string() + ".tmp"));
  // Room again: the write succeeds; stale temps of dead processes are cleaned.
  std::ofstream(path.string() + ".tmp", std::ios::binary) << "stale";
  std::ofstream(path.string() + ".2147483646.0.tmp", std::ios::binary) << "stale";
  CHECK_NOTHROW(write());
  CHECK(slurp(path) != "old contents");
  for (const auto& e : fs::directory_iterator(path.parent_path()))
    CHECK_FALSE((e.path().filename().string().rfind(path.filename().string() + ".", 0) == 0 &&
                 e.path().extension() == ".tmp"));
}

}  // namespace

TEST_CASE("write_file_atomic: all or nothing", "[io][atomic]") {
  const fs::path dir = fs::temp_directory_path() / "gatcore_atomic_test";
  fs::create_directories(dir);
  const std::string big(4096, 'x');
  check_full_disk(dir / "plain.bin", [&] { write_file_atomic((dir / "plain.bin").string(), big); });
  CHECK(slurp(dir / "plain.bin") == big);
  CHECK_THROWS_WITH(write_file_atomic((dir / "no_such_dir" / "x.bin").string(), "abc"),
                    Contains("no_such_dir/x.bin") && Contains("No such file or directory"));
}

TEST_CASE("write_file_atomic: the data is on disk before the rename, the rename before it returns", "[io][atomic]") {
  // Writes were not fsync'd before the rename, so a power
  // cut could leave a renamed but empty file.
  const fs::path dir = fs::canonical(fs::temp_directory_path()) / "gatcore_atomic_test";
  fs::create_directories(dir);
  const fs::path path = dir / "synced.bin";
  std::vector<std::string> calls;
  g_calls = &calls;
  write_file_atomic(path.string(), "some bytes");
  g_calls = nullptr;
  REQUIRE(calls.size() == 3);
  CHECK(calls[0].rfind("fsync " + path.string() + ".", 0) == 0);  // the temp file beside it
  CHECK(calls[1].rfind("rename " + path.string() + ".", 0) == 0);
  CHECK(calls[1].find(" -> " + path.string()) != std::string::npos);
  CHECK(calls[2] == "fsync " + dir.string());  // the folder's entry
  CHECK(slurp(path) == "some bytes");
}

TEST_CASE("glTF, point cache, checkpoint and dataset writers fail cleanly on a full disk", "[io][atomic]") {

  const fs::path dir = fs::temp_directory_path() / "gatcore_atomic_test";
  fs::create_directories(dir);
  const character::Character ch = character::procedural_character();
  for (const char* name : {"ch.glb", "ch.gltf"})
    check_full_disk(dir / name, [&] { character::save_gltf_character(ch, (dir / name).string()); });
  CHECK_NOTHROW(character::load_gltf((dir / "ch.glb").string()));

  character::PointCache pc;
  pc.num_points = 100;
  pc.samples.assign(3, std::vector<float>(300, 1.0f));
  check_full_disk(dir / "c.pc2", [&] { character::write_point_cache((dir / "c.pc2").string(), pc); });
  CHECK(character::read_point_cache((dir / "c.pc2").string()).samples.size() == 3);

  models::CheckpointFile f;
  f.metadata["config"] = "x";
  f.tensors.emplace_back("w", Tensor::full(16, 16, 0.5f));
  check_full_disk(dir / "m.gcm", [&] { models::write_checkpoint_file((dir / "m.gcm").string(), f); });
  CHECK(models::read_checkpoint_file((dir / "m.gcm").string()).tensors.size() == 1);

  // gat dataset build's output (its own temp-file code
  // left OUT.tmp behind when the write failed).
  const character::DatasetDescription d =
      character::describe_dataset({"procedural:humanoid:0", "procedural:humanoid:1", "procedural:humanoid:2"}, {});
  check_full_disk(dir / "d.json", [&] { character::save_dataset((dir / "d.json").string(), d); });
  CHECK(character::load_dataset((dir / "d.json").string()).characters.size() == 3);

}
