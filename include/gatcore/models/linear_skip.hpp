#pragma once
// The DenseGATs linear skip (ModelConfig::linear_skip) set to the least-squares
// fit of the training targets from the input columns, before training: the
// network starts as the best per-vertex linear map of its own inputs (what
// examples/experiments/distortion_probe measures) and only has to learn the
// residual, instead of rediscovering a linear function through 18 GAT
// blocks (docs/RESULTS.md: without it the network stayed above the probe
// after 29 CPU-minutes).
#include <vector>

#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::models {

// A per-vertex linear map of the normalised input columns to the
// normalised targets: y = norm(x)·W + b. Also the linear probe `gat eval
// --linear-probe` reports beside the models (the same inputs, no network).
struct LinearMap {
  Tensor W, b;            // [in, out], [1, out]
  double mse_before = 0;  // mean squared normalised target (predicting zero)
  double mse_after = 0;   // of the fit, on the same vertices
  std::int64_t rows = 0;  // vertices fitted
};

// Solves min ||norm(X)·W + b − scale·T||² + ridge·trace(XᵀX)/d·||W||² over
// every vertex of `samples` (double precision, normal equations). Throws
// InvalidArgument when the samples are empty or their widths differ from
// in / out.
LinearMap fit_linear_map(const std::vector<Sample>& samples, const Normaliser& norm, std::int64_t in,
                         std::int64_t out, double ridge = 1e-6);
// Predictions de-normalised like models::predict (divided by the target scale).
Tensor predict_linear(const LinearMap& map, const Sample& s, const Normaliser& norm);

// fit_linear_map written into the model's "skip.W" / "skip.b" (CPU
// parameters: call before Model::to). Throws InvalidArgument when the model
// has no linear skip.
LinearMap fit_linear_skip(Model& model, const std::vector<Sample>& samples, const Normaliser& norm,
                          double ridge = 1e-6);

}  // namespace gatcore::models
