#pragma once
// Global max pooling over each graph of a block-diagonal batch, broadcast back
// to every vertex of that graph: [n, C] -> [n, C].
#include "gatcore/ops.hpp"

namespace gatcore::nn {

inline Var global_max_broadcast(const GraphPtr& g, const Var& x) { return broadcast_segments(g, segment_max(g, x)); }

}  // namespace gatcore::nn
