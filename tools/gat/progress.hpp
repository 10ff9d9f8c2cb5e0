#pragma once
// The progress line of the `gat` commands: what is being done, how far, the
// rate and the time left, redrawn in place on stderr at most a few times a
// second. It draws only when stderr is a terminal and --quiet is not given,
// so logs and pipes get nothing but the commands' summaries. Library code
// never prints: it reports through a gatcore::ProgressFn (gatcore/progress.hpp)
// that callback() returns.
//
// Activity: what the command is doing right now, for main's last-resort
// error message ("out of memory while predicting skin weights").
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

#include "gatcore/progress.hpp"

namespace gat {

// RAII: names what the command does until the end of the scope (nested
// scopes stack). current_activity(): the innermost one now, or, once an
// exception has unwound through some, the innermost it left; "" otherwise.
class Activity {
 public:
  explicit Activity(std::string what);
  ~Activity();
  Activity(const Activity&) = delete;
  Activity& operator=(const Activity&) = delete;

 private:
  std::string previous_;
  int uncaught_;
};
const std::string& current_activity();

class Progress {
 public:
  // `what`: "evaluating test characters"; `unit`: "frames", "characters".
  Progress(std::string what, std::int64_t total, std::string unit, bool quiet);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // `done` of `total` finished; `note` is shown after the counts.
  void update(std::int64_t done, const std::string& note = "");
  void set_total(std::int64_t total) { total_ = total; }
  // Steps of unequal length (read, features, inference, write): a rate and
  // time left computed from them would mislead, so the line shows neither.
  void set_stages() { stages_ = true; }
  // Clears the line (the summary follows on stdout).
  void finish();
  gatcore::ProgressFn callback();
  bool drawing() const { return draw_; }

  // Whether progress lines would be drawn for --quiet = quiet.
  static bool enabled(bool quiet);

 private:
  Activity activity_;  // the progress line's `what` is also what an error happened during
  std::string what_, unit_;
  std::int64_t total_;
  bool draw_, drawn_ = false, stages_ = false;
  std::chrono::steady_clock::time_point start_, last_;
  std::mutex mutex_;  // callback() may be called from worker threads
};

// "00:01:23".
std::string hms(double seconds);


}  // namespace gat
