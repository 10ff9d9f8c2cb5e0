#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <exception>

namespace gat {

namespace {
std::string g_activity;
// The innermost activity an exception left (main prints the error after the
// stack has unwound, when every Activity is gone).
std::string g_failed_during;
}

std::string hms(double s) {
  const long t = long(std::max(0.0, s) + 0.5);
  char b[32];
  std::snprintf(b, sizeof b, "%02ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  return b;
}

bool Progress::enabled(bool quiet) { return !quiet && isatty(fileno(stderr)); }

Progress::Progress(std::string what, std::int64_t total, std::string unit, bool quiet)
    : activity_(what), what_(std::move(what)), unit_(std::move(unit)), total_(total), draw_(enabled(quiet)),
      start_(std::chrono::steady_clock::now()), last_(start_ - std::chrono::seconds(1)) {}

Progress::~Progress() { finish(); }

void Progress::update(std::int64_t done, const std::string& note) {
  if (!draw_) return;
  // A worker thread already drawing: skip this update rather than wait.
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) return;
  const auto now = std::chrono::steady_clock::now();
  // A few redraws a second: a terminal cannot show more, and each costs a write.
  if (now - last_ < std::chrono::milliseconds(200) && done < total_) return;
  last_ = now;
  const double el = std::chrono::duration<double>(now - start_).count();
  const double rate = el > 0 ? double(done) / el : 0.0;
  char line[512];
  int n = std::snprintf(line, sizeof line, "\r\033[K%s: %lld/%lld %s", what_.c_str(), static_cast<long long>(done),
                        static_cast<long long>(total_), unit_.c_str());
  if (total_ > 0 && n > 0 && n < int(sizeof line))
    n += std::snprintf(line + n, sizeof line - std::size_t(n), " (%.0f%%)", 100.0 * double(done) / double(total_));
  if (done > 0 && !stages_ && n > 0 && n < int(sizeof line))
    n += std::snprintf(line + n, sizeof line - std::size_t(n), "  %.3g %s/s  ETA %s", rate, unit_.c_str(),
                       hms(double(total_ - done) / rate).c_str());
  if (!note.empty() && n > 0 && n < int(sizeof line))
    std::snprintf(line + n, sizeof line - std::size_t(n), "  %s", note.c_str());
  std::fputs(line, stderr);
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  std::lock_guard lock(mutex_);
  if (drawn_) {
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
  }
  drawn_ = false;
}

gatcore::ProgressFn Progress::callback() {
  return [this](std::int64_t done, std::int64_t total) {
    total_ = total;
    update(done);
  };
}

Activity::Activity(std::string what) : previous_(std::move(g_activity)), uncaught_(std::uncaught_exceptions()) {
  g_activity = std::move(what);
}
Activity::~Activity() {
  if (std::uncaught_exceptions() > uncaught_ && g_failed_during.empty()) g_failed_during = g_activity;
  g_activity = std::move(previous_);
}
const std::string& current_activity() { return g_failed_during.empty() ? g_activity : g_failed_during; }

}  // namespace gat
