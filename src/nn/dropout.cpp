#include "gatcore/nn/dropout.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/batch_split.hpp"

namespace gatcore::nn {

Var Dropout::forward(const Var& x, bool training, Rng& rng) const {
  if (!training || p <= 0.f) return x;
  GATCORE_CHECK(p < 1.f, "Dropout: p must be < 1, got ", p);
  Tensor mask = Tensor::empty(x.rows(), x.cols());
  const float keep = 1.f / (1.f - p);
  const std::int64_t C = x.cols();
  if (const BatchSplit* split = current_batch_split()) {
    // A batch split over processes: the mask of the whole batch is one
    // stream, row by row; this process draws through it and keeps its rows,
    // so the mask and the generator's state match one process's.
    GATCORE_CHECK(split->placeholder() || x.rows() == split->rows, "Dropout: a batch split over processes drops ",
                  "per-vertex rows only; this process has ", split->rows, " rows of the batch, the input ",
                  x.value().shape_str());
    auto& eng = rng.engine();
    if (split->placeholder()) {
      eng.discard(static_cast<unsigned long long>(split->global_rows * C));
      mask.fill_(1.f);
    } else {
      eng.discard(static_cast<unsigned long long>(split->row_begin * C));
      for (std::int64_t i = 0; i < x.rows(); ++i)
        for (std::int64_t j = 0; j < C; ++j) mask.at(i, j) = rng.uniform() < p ? 0.f : keep;
      eng.discard(static_cast<unsigned long long>((split->global_rows - split->row_begin - split->rows) * C));
    }
  } else {
    for (std::int64_t i = 0; i < x.rows(); ++i)
      for (std::int64_t j = 0; j < C; ++j) mask.at(i, j) = rng.uniform() < p ? 0.f : keep;
  }
  // Drawn on the host (same stream on every device), uploaded explicitly.
  return mul(x, Var(to(mask, x.device())));
}

}  // namespace gatcore::nn
