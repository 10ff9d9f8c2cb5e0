// The training state a checkpoint carries (the train layer's part of
// checkpoint.hpp's format): Adam moments, epoch, lr, RNG, the plateau scheduler and the
// running average of the weights.
#include <algorithm>
#include <charconv>
#include <limits>
#include <sstream>

#include "gatcore/backend.hpp"
#include "gatcore/models/train.hpp"

namespace gatcore::models {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw CheckpointError("checkpoint '" + path + "': " + what);
}

// The tensors a weight average covers, with their checkpoint names, in the
// order of Trainer::averaged(): the parameters, then the buffers.
std::vector<std::pair<std::string, Tensor>> averaged_entries(const Model& model) {
  std::vector<std::pair<std::string, Tensor>> out;
  for (const auto& p : model.registry().params) out.emplace_back(p.name, p.var.value());
  for (const auto& b : model.registry().buffers) out.emplace_back(b.name, b.tensor);
  return out;
}

}  // namespace

void save_checkpoint(const std::string& path, const Model& model, const Normaliser& norm, const Trainer* trainer,
                     const std::map<std::string, std::string>& extra) {
  CheckpointFile f = model_checkpoint(model, norm, extra, path);
  if (trainer && trainer->averaging()) {
    // The model's tensors become the average; the last step's move to
    // "optim.raw.*" (no swap: a CPU model's tensors in `f` share its storage).
    const auto entries = averaged_entries(model);
    for (std::size_t k = 0; k < entries.size(); ++k) {
      auto it = std::find_if(f.tensors.begin(), f.tensors.end(),
                             [&](const auto& nt) { return nt.first == entries[k].first; });
      Tensor raw = it->second;
      it->second = to(trainer->averaged()[k], Device::cpu);
      f.tensors.emplace_back("optim.raw." + entries[k].first, raw);
    }
    // The float's shortest text, so that the file says 0.98, not 0.98000001907.
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, trainer->options().average_decay).ptr;
    f.metadata["average_decay"] = std::string(text, end);
  }
  if (trainer) {
    auto& t = const_cast<Trainer&>(*trainer);
    const auto& params = model.registry().params;
    for (std::size_t k = 0; k < params.size(); ++k) {
      f.tensors.emplace_back("optim.m." + params[k].name, to(t.optimiser().first_moments()[k], Device::cpu));
      f.tensors.emplace_back("optim.v." + params[k].name, to(t.optimiser().second_moments()[k], Device::cpu));
    }
    f.metadata["epoch"] = std::to_string(t.epoch());
    f.metadata["lr"] = metadata_text(t.optimiser().lr());
    f.metadata["adam_steps"] = std::to_string(t.optimiser().steps());
    f.metadata["rng"] = metadata_text(t.rng());
    f.metadata["plateau_best"] = metadata_text(t.plateau().best);
    f.metadata["plateau_has_best"] = t.plateau().has_best ? "1" : "0";
    f.metadata["plateau_bad_epochs"] = std::to_string(t.plateau().bad_epochs);
    f.metadata["plateau_on_validation"] = t.plateau().on_validation ? "1" : "0";
  }
  write_checkpoint_file(path, f);
}

void restore_training_state(const CheckpointFile& f, Trainer& t, const std::string& path) {
  auto meta = [&](const char* k) {
    auto it = f.metadata.find(k);
    if (it == f.metadata.end()) fail(path, std::string("no training state ('") + k + "' missing): cannot resume");
    return it->second;
  };
  const auto& params = t.model().registry().params;
  for (std::size_t k = 0; k < params.size(); ++k) {
    for (int mv = 0; mv < 2; ++mv) {
      const std::string name = (mv ? "optim.v." : "optim.m.") + params[k].name;
      const Tensor* src = f.find(name);
      if (!src) fail(path, "missing optimiser tensor '" + name + "': cannot resume");
      Tensor& dst = mv ? t.optimiser().second_moments()[k] : t.optimiser().first_moments()[k];
      if (!src->same_shape(dst)) fail(path, "shape mismatch for '" + name + "'");
      if (dst.device() == Device::cpu) dst.copy_from_(*src);
      else backend(dst.device()).copy(to(*src, dst.device()), dst);  // uploaded explicitly
    }
  }
  // A run that averaged: the file's model is the average, and training goes on
  // from the last step's weights and buffers.
  const auto entries = averaged_entries(t.model());
  std::size_t raw = 0;
  for (const auto& [name, v] : entries) raw += f.find("optim.raw." + name) != nullptr;
  if (raw != 0 && raw != entries.size())
    fail(path, "holds the last step's weights ('optim.raw.*') of " + std::to_string(raw) + " of " +
                   std::to_string(entries.size()) + " parameters and buffers: cannot resume");
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const Tensor& v = entries[k].second;
    if (t.averaging()) backend(v.device()).copy(v, t.averaged()[k]);
    if (raw == 0) continue;
    const std::string name = "optim.raw." + entries[k].first;
    const Tensor* src = f.find(name);
    if (!src->same_shape(v)) fail(path, "shape mismatch for '" + name + "'");
    if (v.device() == Device::cpu) v.copy_from_(*src);
    else backend(v.device()).copy(to(*src, v.device()), v);
    v.bump_version();
  }
  for (const char* k : {"epoch", "lr", "adam_steps", "plateau_best", "plateau_has_best", "plateau_bad_epochs"}) meta(k);
  const auto& m = f.metadata;
  t.set_epoch(int(metadata_integer(m, "epoch", 0, std::numeric_limits<int>::max(), path)));
  t.optimiser().set_lr(float(metadata_number(m, "lr", 0.0, 1e6, path)));
  t.optimiser().set_steps(metadata_integer(m, "adam_steps", 0, std::int64_t(1) << 52, path));
  t.plateau().best = float(metadata_number(m, "plateau_best", -3e38, 3e38, path));
  t.plateau().has_best = metadata_flag(m, "plateau_has_best", path);
  t.plateau().bad_epochs = int(metadata_integer(m, "plateau_bad_epochs", 0, std::numeric_limits<int>::max(), path));
  // Absent in checkpoints written before the key existed.
  t.plateau().on_validation = m.count("plateau_on_validation") && metadata_flag(m, "plateau_on_validation", path);
  std::istringstream is(meta("rng"));
  is >> t.rng().engine();
  if (!is) fail(path, "corrupted rng state");
}

TrainingProgress read_training_progress(const CheckpointFile& f, const std::string& path) {
  const auto& m = f.metadata;
  TrainingProgress p;
  if (m.count("epoch")) p.epoch = int(metadata_integer(m, "epoch", 0, std::numeric_limits<int>::max(), path));
  if (m.count("lr")) p.lr = metadata_number(m, "lr", 0.0, 1e6, path);
  if (m.count("adam_steps")) p.adam_steps = metadata_integer(m, "adam_steps", 0, std::int64_t(1) << 52, path);
  if (m.count("average_decay")) p.average_decay = metadata_number(m, "average_decay", 0.0, 0.999999, path);
  for (const auto& [name, t] : f.tensors)
    if (name.rfind("optim.", 0) == 0 && t.numel() > 0) p.resumable = true;
  return p;
}

}  // namespace gatcore::models
