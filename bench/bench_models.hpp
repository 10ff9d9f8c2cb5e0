#pragma once
// Whole-model workloads of gatbench, shared by the benchmarks
// (bench_models.cpp) and the peak-memory child process (bench_main.cpp's
// --gatbench_peak_rss=NAME): the real model builders by name
// (gatcore/models), batches of synthetic character meshes (bench_util.hpp)
// through the trainer's own make_batch, Adam as the trainer uses it.
//
// Sizes follow the papers (SPEC.md): node features [p, n, distances to
// J = 65 joints] = 71 columns; NeuroSkinning predicts weights over |B| = 65
// bones. DenseGATs / Ori.GAT batches are 8 characters x 1000 vertices,
// NeuroSkinning 12 x 2048; inference is one 10k-vertex character.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench_util.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/ops.hpp"
#include "gatcore/optim.hpp"

namespace gatbench {

inline constexpr std::int64_t kFeatures = 71;  // 3 + 3 + 65 joint distances
inline constexpr std::int64_t kBones = 65;     // NeuroSkinning output width

struct ModelWorkload {
  std::string name;  // model name for make_model
  int batch = 0;
  std::int64_t vertices = 0;  // per character
  // The training step's product precision (ProductPrecisionScope; bf16 runs
  // fp32 on a CPU without AVX512_BF16, as the Trainer would).
  gatcore::Precision precision = gatcore::Precision::fp32;
  // Benchmark name suffix: model_train/<name><suffix>.
  std::string suffix() const { return precision == gatcore::Precision::bf16 ? "_bf16" : ""; }
};

// The training workloads, by benchmark name.
inline const std::vector<std::pair<std::string, ModelWorkload>>& train_workloads() {
  static const std::vector<std::pair<std::string, ModelWorkload>> w = {
      {"densegats_train", {"densegats", 8, 1000}},
      {"origat_train", {"origat", 8, 1000}},
      {"neuroskinning_train", {"neuroskinning", 12, 2048}},
      {"densegats_train_bf16", {"densegats", 8, 1000, gatcore::Precision::bf16}},
      {"origat_train_bf16", {"origat", 8, 1000, gatcore::Precision::bf16}},
      {"neuroskinning_train_bf16", {"neuroskinning", 12, 2048, gatcore::Precision::bf16}},
  };
  return w;
}

// One character: a mesh of `vertices` vertices with random features (already
// normalised scale) and a target of the task's width (skin weights: rows
// sum to 1).
inline gatcore::models::Sample mesh_sample(std::int64_t vertices, std::int64_t out_dim, bool weights,
                                           std::uint32_t seed) {
  gatcore::models::Sample s;
  s.name = "mesh" + std::to_string(seed);
  s.graph = gatcore::share(mesh_graph(vertices));
  s.features = random_tensor(vertices, kFeatures, seed);
  s.target = random_tensor(vertices, out_dim, seed + 1000, weights ? 0.0f : -0.1f, weights ? 1.0f : 0.1f);
  if (weights)
    for (std::int64_t i = 0; i < vertices; ++i) {
      float sum = 0;
      for (std::int64_t j = 0; j < out_dim; ++j) sum += s.target.at(i, j);
      for (std::int64_t j = 0; j < out_dim; ++j) s.target.at(i, j) /= sum;
    }
  return s;
}

// A model, one fixed batch and its optimiser: step() is one training step
// (forward, loss, backward, Adam), infer() one eval-mode forward without tape.
struct ModelCase {
  std::unique_ptr<gatcore::models::Model> model;
  gatcore::models::Batch batch;
  std::unique_ptr<gatcore::Adam> adam;
  gatcore::Precision precision = gatcore::Precision::fp32;

  ModelCase(const std::string& name, int batch_size, std::int64_t vertices,
            gatcore::Precision prec = gatcore::Precision::fp32) {
    precision = gatcore::models::training_precision(prec, gatcore::Device::cpu);
    using namespace gatcore::models;
    const bool weights = name.rfind("neuroskinning", 0) == 0;
    ModelConfig cfg = ModelConfig::defaults(name, kFeatures, weights ? kBones : 3);
    model = make_model(cfg, 1);
    std::vector<Sample> samples;
    for (int b = 0; b < batch_size; ++b)
      samples.push_back(mesh_sample(vertices, cfg.out_dim, weights, static_cast<std::uint32_t>(100 + b)));
    std::vector<const Sample*> ptrs;
    for (const Sample& s : samples) ptrs.push_back(&s);
    // Identity normaliser: the features are already on a unit scale.
    Normaliser norm;
    norm.mean = gatcore::Tensor::zeros(1, kFeatures);
    norm.inv_std = gatcore::Tensor::full(1, kFeatures, 1.0f);
    batch = make_batch(ptrs, std::vector<std::vector<std::int32_t>>(ptrs.size()), norm, model->pool_sizes());
    adam = std::make_unique<gatcore::Adam>(model->parameters());
  }

  float step() const {
    gatcore::ProductPrecisionScope scope(precision);
    gatcore::Var loss = gatcore::models::task_loss(model->config(), model->forward(batch, true), batch.target);
    adam->zero_grad();
    gatcore::backward(loss);
    adam->step();
    return loss.value().at(0, 0);
  }

  void infer() const {
    gatcore::NoGradGuard ng;
    gatcore::Var y = model->forward(batch, false);
    benchmark::DoNotOptimize(y.value().data());
  }
};

// The child side of model_peak_rss (bench_peak_rss.cpp): builds the workload
// `name` (a train_workloads() key), notes the peak RSS, runs `steps`
// training steps and prints "setup_peak_kib total_peak_kib median_step_ms".
int peak_rss_main(const std::string& name, int steps);

}  // namespace gatbench
