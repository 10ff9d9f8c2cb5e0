#pragma once
// A training batch split over processes (data-parallel training, dist/).
//
// Almost every op works row by row, so a process can run its share of a
// batch alone. Two cannot: BatchNorm's statistics are over the whole batch
// (SyncBatchNorm), and Dropout's mask is drawn row by row from one random
// stream. While a BatchSplitScope is alive they consult current_batch_split().
// This header is the whole interface between the ops and the communication
// layer: the ops never see a communicator, only a sum.
#include <cstddef>
#include <cstdint>
#include <functional>

namespace gatcore {

// In-place element-wise sum of `n` doubles over the processes; every process
// passes the same n and gets the same bits back.
using SumAcross = std::function<void(double* data, std::size_t n)>;

struct BatchSplit {
  SumAcross sum;
  // This process's rows of the batch's per-vertex tensors: [row_begin,
  // row_begin + rows) of global_rows. rows = 0 with a non-empty local batch:
  // a placeholder share (a batch with fewer characters than processes); it
  // runs the model so that it takes part in every sum, but adds nothing.
  std::int64_t row_begin = 0, rows = 0, global_rows = 0;
  bool placeholder() const { return rows == 0; }
};

// The split in force on this thread, or nullptr (a whole batch in one process).
const BatchSplit* current_batch_split();

// Puts a split in force for its lifetime (one training step).
class BatchSplitScope {
 public:
  explicit BatchSplitScope(const BatchSplit& s);
  ~BatchSplitScope();
  BatchSplitScope(const BatchSplitScope&) = delete;
  BatchSplitScope& operator=(const BatchSplitScope&) = delete;

 private:
  const BatchSplit* prev_;
};

}  // namespace gatcore
