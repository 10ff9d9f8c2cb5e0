#pragma once
// The pieces of data-parallel training the Trainer (models/train.hpp) uses:
// which part of a batch is this rank's, the gradient sum after backward, and
// keeping the ranks' copies of the model identical.
#include <cstddef>
#include <vector>

#include "gatcore/autograd.hpp"
#include "gatcore/dist/communicator.hpp"

namespace gatcore::dist {

// The rule that shards a batch of `count` items (characters, in the order
// the single-process run would batch them) over `size` ranks: rank r gets
// the contiguous items [count·r/size, count·(r+1)/size). Contiguous, so the
// ranks' rows laid end to end in rank order are the single-process batch.
struct Share {
  std::size_t begin = 0, end = 0;
  bool empty() const { return begin == end; }
};
Share share_of(std::size_t count, int rank, int size);

// Sums the parameters' gradients over the ranks, in place: one flat float
// buffer per step (every parameter's gradient, plus one has-a-gradient flag
// per parameter), one ordered sum. A parameter no rank has a gradient for
// keeps none (Adam skips it, as in one process).
void sum_gradients(Communicator& comm, const std::vector<Var>& params);

// Rank `root`'s values of the tensors to every rank (the tensors may live on
// any device; same shapes on every rank).
void broadcast_tensors(Communicator& comm, const std::vector<Tensor>& tensors, int root = 0);

}  // namespace gatcore::dist
