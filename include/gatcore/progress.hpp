#pragma once
// How long-running library functions report progress without printing:
// they call a ProgressFn (when one is given) with the work done so far and
// the total, in the caller's unit (characters, samples, frames). Callers
// draw it (the `gat` tool's progress line) or ignore it.
#include <cstdint>
#include <functional>
#include <string>

namespace gatcore {

using ProgressFn = std::function<void(std::int64_t done, std::int64_t total)>;

// Calls `fn` when set.
inline void report_progress(const ProgressFn& fn, std::int64_t done, std::int64_t total) {
  if (fn) fn(done, total);
}

// How readers that accept a slightly malformed file (a BVH whose Frames:
// count disagrees with its data) say what they assumed: one sentence naming
// the file and what was read. Without one the message goes to stderr, so a
// lenient read is never silent.
using WarningFn = std::function<void(const std::string& message)>;

// Calls `fn` when set, else prints "warning: MESSAGE" on stderr.
void report_warning(const WarningFn& fn, const std::string& message);

}  // namespace gatcore
