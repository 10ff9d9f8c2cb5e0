#include "gatcore/models/model.hpp"
#include "gatcore/backend.hpp"

#include <algorithm>
#include <numeric>

#include "models_impl.hpp"

namespace gatcore::models {

std::vector<std::string> model_names() {
  std::vector<std::string> names;
  for (ModelKind k : all_model_kinds()) names.emplace_back(model_kind_name(k));
  return names;
}

std::unique_ptr<Model> make_model(const ModelConfig& cfg, std::uint64_t seed) {
  GATCORE_CHECK(cfg.in_dim > 0, "model '", cfg.name, "': in_dim must be positive");
  GATCORE_CHECK(cfg.out_dim > 0, "model '", cfg.name, "': out_dim must be positive");
  GATCORE_CHECK(cfg.task == Task::weights || cfg.out_dim == 3, "model '", cfg.name,
                "': the displacement task has 3 outputs, got out_dim ", cfg.out_dim);
  switch (cfg.kind()) {  // throws the "unknown model" message
    case ModelKind::densegats:
    case ModelKind::densegats_noself:
    case ModelKind::densegats_nodense: return detail::make_densegats(cfg, seed);
    case ModelKind::origat: return detail::make_origat(cfg, seed);
    case ModelKind::neuroskinning:
    case ModelKind::neuroskinning_nopool:
    case ModelKind::skinweights_any: return detail::make_neuroskinning(cfg, seed);
    case ModelKind::fc: return detail::make_fc(cfg, seed);
    case ModelKind::pointnet: return detail::make_pointnet(cfg, seed);
  }
  return nullptr;
}

Var Model::output(const Var& logits, const Batch& b) const {
  if (cfg_.task == Task::displacement) return logits;
  return masked_softmax(logits, b.mask);
}

Var masked_softmax(const Var& logits, const Tensor& mask) {
  if (!mask.defined() || mask.rows() == 1) return row_softmax(logits, mask);
  check_shape(mask, logits.rows(), logits.cols(), "bone mask");
  // Per-row masks: a -1e9 bias underflows exp() to exactly 0.
  if (mask.device() != Device::cpu) {
    // On the device: bias = 1e9·mask − 1e9 (masks are 0/1: exactly 0 or −1e9).
    Backend& be = backend(mask.device());
    Tensor bias = be.empty(mask.rows(), mask.cols());
    be.fill(bias, 1.f);
    be.axpby(1e9f, mask, -1e9f, bias, bias);
    return row_softmax(add(logits, Var(bias)));
  }
  Tensor bias = Tensor::empty(mask.rows(), mask.cols());
  for (std::int64_t i = 0; i < mask.rows(); ++i)
    for (std::int64_t j = 0; j < mask.cols(); ++j) bias.at(i, j) = mask.at(i, j) != 0.f ? 0.f : -1e9f;
  return row_softmax(add(logits, Var(bias)));
}

Tensor top_k_renormalise(const Tensor& w, int k) {
  GATCORE_CHECK(k > 0, "top_k_renormalise: k must be positive, got ", k);
  Tensor out = Tensor::zeros(w.rows(), w.cols());
  std::vector<std::int64_t> idx(std::size_t(w.cols()));
  for (std::int64_t i = 0; i < w.rows(); ++i) {
    std::iota(idx.begin(), idx.end(), 0);
    const auto kk = std::min<std::int64_t>(k, w.cols());
    std::partial_sort(idx.begin(), idx.begin() + kk, idx.end(), [&](std::int64_t a, std::int64_t b) {
      return w.at(i, a) > w.at(i, b) || (w.at(i, a) == w.at(i, b) && a < b);
    });
    double s = 0;
    for (std::int64_t t = 0; t < kk; ++t) s += std::max(0.f, w.at(i, idx[t]));
    for (std::int64_t t = 0; t < kk; ++t)
      out.at(i, idx[t]) = s > 0 ? float(std::max(0.f, w.at(i, idx[t])) / s) : 0.f;
  }
  return out;
}

Var task_loss(const ModelConfig& cfg, const Var& pred, const Tensor& target) {
  if (cfg.task == Task::weights && cfg.weight_loss == WeightLoss::kl) return kl_div_loss(pred, target);
  if (cfg.task == Task::displacement && cfg.loss == DisplacementLoss::mse) return mse_loss(pred, target);
  // |d| = relu(d) + relu(-d), from ops every backend has.
  check_shape(target, pred.rows(), pred.cols(), "l1 loss target");
  const Var d = sub(pred, Var(target));
  const Var l1 = mean(add(activation(Activation::relu, d), activation(Activation::relu, scale(d, -1.0f))));
  // Weights: the sum over a vertex's bones (the L1 gat eval reports), mean over vertices.
  return cfg.task == Task::weights ? scale(l1, float(pred.cols())) : l1;
}

}  // namespace gatcore::models
