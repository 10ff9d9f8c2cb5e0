// The real models through the real Trainer on Vulkan: a reduced DenseGATs and
// a reduced NeuroSkinning, built from the same seed on both devices (so the
// same initial weights), trained a few steps with Model::to(Device::vulkan)
// and compared with the CPU run: losses, parameters and BatchNorm buffers.
// No silent CPU fallback: device tensors have no host pointer (any host
// access throws), every parameter and buffer stays on the device, and a
// training step submits exactly once (the loss read).
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "model_fixtures.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

struct Run {
  std::vector<double> losses;
  std::vector<Tensor> params, buffers, averaged;  // CPU copies
  std::vector<std::string> names, buffer_names;
  std::vector<std::uint64_t> submits;   // per step (Vulkan)
};

ModelConfig reduced(const std::string& name) {
  ModelConfig c = ModelConfig::defaults(name, 9, name == "neuroskinning" ? 5 : 3);
  if (name == "densegats") {
    c.transform = {8, 8};
    c.modules = 2;
    c.blocks = 2;
    c.heads = 2;
    c.head_dim = 4;
    c.beta = 0.5f;
    c.head = {16, 8};
  } else if (name == "neuroskinning") {
    c.stage1 = {16, 8};
    c.gc_heads = {2, 2, 2};
    c.gc_dims = {8, 8, 8};
    c.gc_pool = {4, 6, 8};
    c.global_mlp = {16, 32};
    c.classifier = {32, 16};
  } else if (name == "origat") {
    c.heads = 2;
    c.head_dim = 4;
  }
  return c;
}

std::vector<Sample> data_for(const ModelConfig& c) {
  const bool w = c.task == Task::weights;
  return {fixtures::wave_sample(8, 6, 0.f, w), fixtures::wave_sample(8, 6, 0.5f, w),
          fixtures::wave_sample(7, 6, 1.f, w)};
}

Run train(const ModelConfig& c, Device d, int epochs, const std::string& save_to = {}, float average_decay = 0.f) {
  const auto data = data_for(c);
  auto m = make_model(c, 11);
  m->to(d);
  REQUIRE(m->device() == d);
  TrainOptions o = TrainOptions::defaults_for(c);
  o.sample_vertices = 25;
  o.batch_size = 4;  // one step per epoch
  o.seed = 5;
  o.average_decay = average_decay;
  Trainer t(*m, o, Normaliser::fit(data, c.task == Task::displacement));
  Run r;
  for (int e = 0; e < epochs; ++e) {
    const auto before = vulkan::stats();
    const EpochStats st = t.run_epoch(data);
    REQUIRE(st.batches == 1);
    r.losses.push_back(st.train_loss);
    r.submits.push_back(vulkan::stats().submits - before.submits);
  }
  for (const auto& p : m->registry().params) {
    REQUIRE(p.var.device() == d);
    r.params.push_back(to(p.var.value(), Device::cpu).clone());
    r.names.push_back(p.name);
  }
  for (const Tensor& a : t.averaged()) {
    REQUIRE(a.device() == d);
    r.averaged.push_back(to(a, Device::cpu).clone());
  }
  for (const auto& b : m->registry().buffers) {
    REQUIRE(b.tensor.device() == d);
    r.buffers.push_back(to(b.tensor, Device::cpu).clone());
    r.buffer_names.push_back(b.name);
  }
  if (d == Device::vulkan) {
    // The guarantee behind "no silent fallback": host access of a device tensor throws.
    REQUIRE_THROWS(m->registry().params.front().var.value().data());
    REQUIRE_THROWS(m->registry().buffers.empty() ? m->registry().params.back().var.value().data()
                                                 : m->registry().buffers.front().tensor.data());
  }
  if (!save_to.empty()) save_checkpoint(save_to, *m, t.normaliser(), &t);
  return r;
}

// Row-vector parameters (biases, BatchNorm γ/β) with a mathematically zero
// gradient (a Linear bias right before a BatchNorm; a β whose constant shift
// the next Linear → BatchNorm removes again) get rounding noise whose sign
// depends on the summation order, and Adam turns any nonzero gradient into a
// step of about lr in the direction of that sign, on each side independently:
// the two runs can drift apart by up to 2 × steps × lr (each moving ~lr per
// step, in opposite directions when the noise signs differ). Matrices, the
// losses and the BatchNorm running variances are compared tightly (running
// means follow those biases: the same bound).
// float32 on both sides, different summation orders: losses within 1e-4
// relative; parameters and BatchNorm statistics within 1e-3 relative + 1e-4
// absolute after the steps (row-vector parameters: steps × lr absolute).
void compare(const Run& c, const Run& g, float lr) {
  REQUIRE(c.losses.size() == g.losses.size());
  for (std::size_t s = 0; s < c.losses.size(); ++s) {
    INFO("step " << s << ": cpu " << c.losses[s] << ", vulkan " << g.losses[s]);
    REQUIRE(g.losses[s] == Approx(c.losses[s]).epsilon(1e-4));
  }
  REQUIRE(c.params.size() == g.params.size());
  const float noise_bound = 2.0f * 1.01f * lr * float(c.losses.size());
  for (std::size_t k = 0; k < c.params.size(); ++k) {
    INFO("parameter " << k << " " << c.names[k]);
    const bool noise = c.params[k].rows() == 1;
    vkt::require_close(c.params[k], g.params[k], 1e-3f, noise ? noise_bound : 1e-4f, "parameter");
  }
  REQUIRE(c.averaged.size() == g.averaged.size());
  for (std::size_t k = 0; k < c.averaged.size(); ++k) {  // the parameters, then the buffers
    const bool param = k < c.names.size();
    const std::string& name = param ? c.names[k] : c.buffer_names[k - c.names.size()];
    INFO("averaged " << k << " " << name);
    const bool noise = param ? c.averaged[k].rows() == 1 : name.find("running_mean") != std::string::npos;
    vkt::require_close(c.averaged[k], g.averaged[k], 1e-3f, noise ? noise_bound : 1e-4f, "averaged tensor");
  }
  for (std::size_t k = 0; k < c.buffers.size(); ++k) {
    INFO("buffer " << k << " " << c.buffer_names[k]);
    // A running mean follows the batch mean, which those biases shift 1:1.
    const bool mean = c.buffer_names[k].find("running_mean") != std::string::npos;
    vkt::require_close(c.buffers[k], g.buffers[k], 1e-3f, mean ? noise_bound : 1e-4f, "buffer");
  }
}

void parity(const ModelConfig& c, float average_decay = 0.f) {
  const int epochs = 4;
  const Run cpu = train(c, Device::cpu, epochs, {}, average_decay);
  const Run vk = train(c, Device::vulkan, epochs, {}, average_decay);
  compare(cpu, vk, TrainOptions::defaults_for(c).lr);
  // One submission per training step: the loss read (first step included:
  // uploads of parameters, batch data and graphs are recorded, not submitted).
  for (std::size_t s = 0; s < vk.submits.size(); ++s) {
    INFO("step " << s);
    CHECK(vk.submits[s] == 1);
  }
}

void parity(const std::string& name) { parity(reduced(name)); }

}  // namespace

TEST_CASE("vulkan trainer: reduced DenseGATs trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  parity("densegats");
}

TEST_CASE("vulkan trainer: reduced DenseGATs with the linear skip trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  ModelConfig c = reduced("densegats");
  c.linear_skip = true;
  parity(c);
}

TEST_CASE("vulkan trainer: the moving average of the weights follows the CPU's, with no extra submission", "[vulkan]") {
  if (!vkt::ready()) return;
  parity(reduced("densegats"), 0.5f);
  // A device checkpoint holds the average as the model, the last step's weights beside it.
  const ModelConfig c = reduced("densegats");
  const auto path = (std::filesystem::temp_directory_path() /
                     ("gatcore_vk_average_" + std::to_string(::getpid()) + ".gcm"))
                        .string();
  const Run vk = train(c, Device::vulkan, 3, path, 0.5f);
  LoadedModel l = load_checkpoint(path);
  REQUIRE(vk.averaged.size() == vk.params.size() + vk.buffers.size());
  for (std::size_t k = 0; k < vk.params.size(); ++k) {
    vkt::require_close(vk.averaged[k], l.model->registry().params[k].var.value(), 0.f, 0.f, "saved average");
    const Tensor* raw = l.file.find("optim.raw." + vk.names[k]);
    REQUIRE(raw);
    vkt::require_close(vk.params[k], *raw, 0.f, 0.f, "saved last-step weights");
  }
  for (std::size_t k = 0; k < vk.buffers.size(); ++k) {
    vkt::require_close(vk.averaged[vk.params.size() + k], l.model->registry().buffers[k].tensor, 0.f, 0.f,
                       "saved averaged buffer");
    const Tensor* raw = l.file.find("optim.raw." + vk.buffer_names[k]);
    REQUIRE(raw);
    vkt::require_close(vk.buffers[k], *raw, 0.f, 0.f, "saved last-step buffer");
  }
  std::filesystem::remove(path);
}

TEST_CASE("vulkan trainer: reduced NeuroSkinning trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  parity("neuroskinning");
}

TEST_CASE("vulkan trainer: Ori.GAT trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  parity("origat");
}

TEST_CASE("vulkan trainer: checkpoints from the device resume on it and evaluate like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  const ModelConfig c = reduced("densegats");
  const auto path = (std::filesystem::temp_directory_path() /
                     ("gatcore_vk_trainer_" + std::to_string(::getpid()) + ".gcm"))  // ctest -j: one per process
                        .string();
  const Run vk = train(c, Device::vulkan, 2, path);
  LoadedModel l = load_checkpoint(path);
  for (std::size_t k = 0; k < vk.params.size(); ++k)
    vkt::require_close(vk.params[k], l.model->registry().params[k].var.value(), 0.f, 0.f, "saved parameter");
  // Resume on the device: the Adam moments are uploaded into the device trainer.
  l.model->to(Device::vulkan);
  const auto data = data_for(c);
  TrainOptions o = TrainOptions::defaults_for(c);
  o.sample_vertices = 25;
  o.batch_size = 4;
  Trainer t(*l.model, o, l.norm);
  restore_training_state(l.file, t, path);
  REQUIRE(t.epoch() == 2);
  REQUIRE(std::isfinite(t.run_epoch(data).train_loss));
  // Eval-mode loss and predictions on the device match the CPU copy of the same model.
  LoadedModel h = load_checkpoint(path);
  Trainer tc(*h.model, o, h.norm);
  LoadedModel d = load_checkpoint(path);
  d.model->to(Device::vulkan);
  Trainer td(*d.model, o, d.norm);
  REQUIRE(td.evaluate(data) == Approx(tc.evaluate(data)).epsilon(1e-4));
  const Tensor pc = predict(*h.model, data[0], h.norm), pd = predict(*d.model, data[0], d.norm);
  REQUIRE(pd.device() == Device::cpu);
  vkt::require_close(pc, pd, 1e-3f, 1e-4f, "prediction");
  // Folding BatchNorm on the device (gat eval) keeps the outputs.
  h.model->fold_batch_norm();
  d.model->fold_batch_norm();
  vkt::require_close(predict(*h.model, data[0], h.norm), predict(*d.model, data[0], d.norm), 1e-3f, 1e-4f,
                     "folded prediction");
  std::filesystem::remove(path);
}
