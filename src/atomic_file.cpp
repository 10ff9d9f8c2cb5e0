#include "gatcore/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "gatcore/error.hpp"

namespace gatcore {

namespace {

// Temp files of earlier writes to `path` whose process is gone (killed
// mid-write): "<path>.<pid>.<n>.tmp" with a dead pid, and the plain
// "<path>.tmp" of older versions. A live process's temp is left alone.
void remove_stale_temps(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  const std::string prefix = p.filename().string() + ".";
  std::error_code ec;
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name == prefix + "tmp") {  // "<path>.tmp" of older versions
      ::unlink(it->path().c_str());
      continue;
    }
    if (name.size() <= prefix.size() + 4 || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - 4, 4, ".tmp") != 0)
      continue;
    const std::string mid = name.substr(prefix.size(), name.size() - prefix.size() - 4);  // "<pid>.<n>" or ""
    const long pid = std::strtol(mid.c_str(), nullptr, 10);
    bool dead;
    if (mid.empty()) dead = false;
    else if (mid.find_first_not_of("0123456789.") != std::string::npos) dead = false;  // not one of ours
    else dead = pid <= 0 || (::kill(pid_t(pid), 0) != 0 && errno == ESRCH);
    if (dead) ::unlink(it->path().c_str());
  }
}

}  // namespace

void write_file_atomic(const std::string& path, std::string_view bytes) {
  remove_stale_temps(path);
  // Unique per process and call: concurrent writers of one path (two test
  // processes, two threads) each rename a whole file; the last one wins.
  static std::atomic<unsigned long> counter{0};
  const std::string tmp = path + "." + std::to_string(::getpid()) + "." + std::to_string(counter++) + ".tmp";
  auto fail = [&](const char* step, int err) {
    throw InvalidArgument(detail::cat(path, ": ", step, " failed: ", std::strerror(err), " (nothing written)"));
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail(("creating '" + tmp + "'").c_str(), errno);
  auto abandon = [&](const char* step) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    fail(step, err);
  };
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ::ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      abandon("write");
    }
    if (n == 0) {
      errno = ENOSPC;
      abandon("write");
    }
    done += std::size_t(n);
  }
  if (::fsync(fd) != 0) abandon("fsync");
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    fail("close", err);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    fail(("renaming '" + tmp + "' over it").c_str(), err);
  }
  // The rename is durable once the folder's entry is on disk; a failure here
  // leaves a complete file, so it is not reported.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::string dir = parent.empty() ? std::string(".") : parent.string();
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

}  // namespace gatcore
