#include "gatcore/batch_split.hpp"

namespace gatcore {

namespace {
// Thread-local: the step runs on the thread that called the trainer.
thread_local const BatchSplit* g_split = nullptr;
}  // namespace

const BatchSplit* current_batch_split() { return g_split; }

BatchSplitScope::BatchSplitScope(const BatchSplit& s) : prev_(g_split) { g_split = &s; }
BatchSplitScope::~BatchSplitScope() { g_split = prev_; }

}  // namespace gatcore
