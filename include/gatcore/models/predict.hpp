#pragma once
// A model applied to samples: block-diagonal batches and predictions on full
// meshes in eval mode (what inference needs, without the trainer).
#include <map>
#include <vector>

#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::models {

// Neighbour lists by breadth-first hop distance (ties by vertex id), the
// vertex itself first, at most k per vertex.
std::vector<std::vector<std::int32_t>> hop_neighbours(const CsrGraph& g, int k);

// One block-diagonal batch of the given samples restricted to the given
// vertex selections (empty selection = all vertices), with normalised
// features, targets, bone masks, log priors (all samples or none) and the
// neighbour graphs of `pool_sizes`.
Batch make_batch(const std::vector<const Sample*>& samples, const std::vector<std::vector<std::int32_t>>& selections,
                 const Normaliser& norm, const std::vector<int>& pool_sizes);

// Moves the batch's features, target, mask and prior to `d` (graphs stay: backends
// upload them themselves).
void to_device(Batch& b, Device d);

// A batch's graphs die with the batch; drops their device copies (the Vulkan
// graph cache is keyed by address, which the next batch's graphs may reuse).
void forget_graphs(const Batch& b, Device d);

// Predictions on one full sample in eval mode, de-normalised (displacements
// divided by the target scale; weights top-κ renormalised if top_k > 0).
Tensor predict(Model& model, const Sample& s, const Normaliser& norm, int top_k = 0);

}  // namespace gatcore::models
