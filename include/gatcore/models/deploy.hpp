#pragma once
// The deploy-time path of a displacement model (densegats, its ablations,
// origat): inference without the autodiff tape and without allocation per
// call.
//
// DeployModel: the trained weights as inference needs them, immutable, shared
// by every character and thread: every BatchNorm that follows a Linear folded
// into it (Model::fold_batch_norm), the GAT blocks' BatchNorms (after a
// nonlinearity, not foldable) reduced to a per-column mean / scale / shift, and
// the feature normaliser.
//
// DeployPlan: one character's graph and every intermediate tensor of a
// forward pass for it, allocated once; run() calls the backend's forward
// kernels straight into them in the order Model::forward does, so the results
// are bitwise those of models::predict on the folded model in fp32 (tested;
// the CPU's products with pre-packed weights are gemm()'s arithmetic), and
// within bf16's rounding of it in bf16 (tested, test_runtime). One plan
// per character and thread (it owns its workspace); plans of one DeployModel
// may run concurrently on the CPU.
//
// On the CPU run() allocates nothing (tested with a counting allocator). On
// Vulkan the input upload and output download are transfers through
// Backend::from_host / to_host (they allocate staging memory), and the Vulkan
// backend is one global command stream: run Vulkan plans from one thread.
#include <cstdint>
#include <memory>
#include <vector>

#include "gatcore/models/model.hpp"
#include "gatcore/precision.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::models {

struct DeployModel;

// Whether `cfg` has a deploy path (displacement task; densegats family, origat).
bool deployable(const ModelConfig& cfg);
// Folds `model`'s BatchNorms (the model is left folded: inference only) and
// copies its weights to `device` (Device::cpu or an initialised Vulkan
// backend); on the CPU the weights are also packed once for the products
// (src/backends/cpu/inference.hpp) in `precision`. Throws InvalidArgument for
// models without a deploy path, and for bf16 off the CPU or on a CPU without
// AVX512_BF16 (bf16_supported()).
std::shared_ptr<const DeployModel> make_deploy_model(Model& model, const Normaliser& norm,
                                                     Device device = Device::cpu,
                                                     Precision precision = Precision::fp32);
const ModelConfig& deploy_config(const DeployModel& m);
Device deploy_device(const DeployModel& m);
Precision deploy_precision(const DeployModel& m);
// Scalars in the deploy model (the folded model's parameter count).
std::int64_t deploy_parameter_count(const DeployModel& m);

class DeployPlan {
 public:
  // `graph`: the character's mesh graph (self-loops, symmetric), kept alive by the plan.
  DeployPlan(std::shared_ptr<const DeployModel> model, GraphPtr graph);
  ~DeployPlan();
  DeployPlan(const DeployPlan&) = delete;
  DeployPlan& operator=(const DeployPlan&) = delete;

  std::int64_t num_nodes() const { return n_; }
  // [n, in_dim] host tensor: the caller writes the raw (un-normalised)
  // features here before run().
  const Tensor& input() const { return x_host_; }
  // Normalises input() in place, runs the model, returns [n, out_dim] host
  // predictions divided by the target scale (models::predict's values).
  const Tensor& run();
  // Bytes of the activations and scratch this plan holds (host or device;
  // the model's weights are the DeployModel's): what embedding one
  // character costs besides the model. Buffers only the unfused GAT block
  // needs are allocated when the plan is built for that path; a plan built
  // at the AVX-512 level and run after the SIMD level was lowered
  // (cpu::set_simd_level) allocates them in that run, so the figure can
  // grow once.
  std::int64_t scratch_bytes() const;

 private:
  struct Buffers;
  std::shared_ptr<const DeployModel> model_;
  GraphPtr graph_;
  std::int64_t n_ = 0;
  Tensor x_host_, y_host_;
  std::unique_ptr<Buffers> buf_;
};

}  // namespace gatcore::models
