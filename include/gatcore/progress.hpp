#pragma once
// How long-running library functions report progress without printing:
// they call a ProgressFn (when one is given) with the work done so far and
// the total, in the caller's unit (characters, samples, frames). Callers
// draw it (the `gat` tool's progress line) or ignore it.
#include <cstdint>
#include <functional>

namespace gatcore {

using ProgressFn = std::function<void(std::int64_t done, std::int64_t total)>;

// Calls `fn` when set.
inline void report_progress(const ProgressFn& fn, std::int64_t done, std::int64_t total) {
  if (fn) fn(done, total);
}

}  // namespace gatcore
