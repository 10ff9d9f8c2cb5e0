#include "gatcore/models/train.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/batch_split.hpp"
#include "gatcore/dist/data_parallel.hpp"
#include "gatcore/vulkan.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <numbers>
#include <numeric>

namespace gatcore::models {

const char* sampling_name(Sampling s) {
  return s == Sampling::full ? "full" : s == Sampling::random ? "random" : "consecutive";
}

Sampling sampling_from_name(const std::string& name) {
  for (Sampling s : {Sampling::full, Sampling::consecutive, Sampling::random})
    if (name == sampling_name(s)) return s;
  throw InvalidArgument("unknown sampling '" + name + "' (full, consecutive, random)");
}

TrainOptions TrainOptions::defaults_for(const ModelConfig& cfg) {
  TrainOptions o;
  if (uses_neuroskinning_features(cfg.kind())) {
    o.batch_size = 12;
    o.sampling = Sampling::random;
    o.sample_vertices = 2048;
    o.schedule = Schedule::step;
  }
  return o;
}

const char* schedule_name(Schedule s) {
  switch (s) {
    case Schedule::plateau: return "plateau";
    case Schedule::step: return "step";
    case Schedule::cosine: return "cosine";
  }
  return "plateau";
}

Schedule schedule_from_name(const std::string& name, const char* what) {
  for (Schedule s : {Schedule::plateau, Schedule::step, Schedule::cosine})
    if (name == schedule_name(s)) return s;
  throw InvalidArgument(std::string(what) + ": unknown learning-rate schedule '" + name + "' (plateau, step, cosine)");
}

float cosine_lr(float lr0, float lr_min, double progress) {
  const double p = std::clamp(progress, 0.0, 1.0);
  return float(double(lr_min) + (double(lr0) - double(lr_min)) * 0.5 * (1.0 + std::cos(std::numbers::pi * p)));
}

float PlateauScheduler::step(float metric, float lr) {
  if (!has_best || metric < best * (1.f - 1e-4f)) {
    best = metric;
    has_best = true;
    bad_epochs = 0;
    return lr;
  }
  if (++bad_epochs > patience) {
    bad_epochs = 0;
    return std::max(min_lr, lr * factor);
  }
  return lr;
}

std::vector<std::int32_t> sample_vertices(std::int64_t n, Sampling s, std::int64_t k, nn::Rng& rng) {
  std::vector<std::int32_t> v;
  if (s == Sampling::full || k >= n) {
    v.resize(std::size_t(n));
    std::iota(v.begin(), v.end(), 0);
    return v;
  }
  if (s == Sampling::consecutive) {
    const auto start = std::int32_t(rng.below(std::uint64_t(n - k + 1)));
    v.resize(std::size_t(k));
    std::iota(v.begin(), v.end(), start);
    return v;
  }
  // Partial Fisher-Yates, then sorted (locality of the induced subgraph).
  std::vector<std::int32_t> all(static_cast<std::size_t>(n));
  std::iota(all.begin(), all.end(), 0);
  for (std::int64_t i = 0; i < k; ++i) std::swap(all[std::size_t(i)], all[std::size_t(i + std::int64_t(rng.below(std::uint64_t(n - i))))]);
  v.assign(all.begin(), all.begin() + k);
  std::sort(v.begin(), v.end());
  return v;
}

Precision training_precision(Precision requested, Device d, std::string* why) {
  if (why) why->clear();
  if (requested == Precision::fp32 || backend(d).bf16_products()) return requested;
  if (why)
    *why = d == Device::cpu ? "this CPU has no AVX512_BF16 (or GATCORE_SIMD lowers the level): training in fp32"
                            : std::string("the ") + device_name(d) + " backend has no bf16 products: training in fp32";
  return Precision::fp32;
}

Trainer::Trainer(Model& model, TrainOptions opt, Normaliser norm, dist::Communicator& comm)
    : model_(model), comm_(comm), opt_(opt), norm_(std::move(norm)), adam_(model.parameters(), AdamOptions{opt.lr}),
      rng_(opt.seed ^ 0x5851f42d4c957f2dull) {
  opt_.precision = training_precision(opt.precision, model.device());
  plateau_.factor = opt.plateau_factor;
  plateau_.patience = opt.plateau_patience;
  plateau_.min_lr = opt.min_lr;
  GATCORE_CHECK(opt.average_decay >= 0.f && opt.average_decay < 1.f, "Trainer: the weight-average decay ",
                opt.average_decay, " is outside [0, 1)");
  if (opt.average_decay > 0.f)
    for (const Tensor& v : averaged_tensors()) {
      Backend& be = backend(v.device());
      average_.push_back(be.empty(v.rows(), v.cols()));
      be.copy(v, average_.back());
    }
}

std::vector<Tensor> Trainer::averaged_tensors() const {
  std::vector<Tensor> out;
  for (const auto& p : model_.registry().params) out.push_back(p.var.value());
  for (const auto& b : model_.registry().buffers) out.push_back(b.tensor);
  return out;
}

void Trainer::update_average() {
  // The warm-up of TensorFlow's ExponentialMovingAverage(num_updates): early
  // on the average follows the parameters closely.
  const double t = double(adam_.steps());
  const float d = std::min(opt_.average_decay, float((1.0 + t) / (10.0 + t)));
  const std::vector<Tensor> live = averaged_tensors();
  for (std::size_t k = 0; k < live.size(); ++k)
    backend(live[k].device()).axpby(d, average_[k], 1.f - d, live[k], average_[k]);
}

void Trainer::swap_averaged() {
  if (average_.empty()) return;
  const std::vector<Tensor> live = averaged_tensors();
  for (std::size_t k = 0; k < live.size(); ++k) {
    const Tensor& v = live[k];
    Backend& be = backend(v.device());
    Tensor keep = be.empty(v.rows(), v.cols());
    be.copy(v, keep);
    be.copy(average_[k], v);
    be.copy(keep, average_[k]);
    v.bump_version();
  }
  swapped_ = !swapped_;
}

namespace {
// The epoch's order of `count` samples: a seeded Fisher-Yates shuffle.
std::vector<std::size_t> epoch_order(std::size_t count, nn::Rng& rng) {
  std::vector<std::size_t> order(count);
  std::iota(order.begin(), order.end(), 0);
  for (std::size_t i = order.size(); i > 1; --i) std::swap(order[i - 1], order[rng.below(i)]);
  return order;
}
}  // namespace

std::vector<bool> Trainer::samples_needed(std::size_t count) const {
  if (comm_.size() == 1) return std::vector<bool>(count, true);
  nn::Rng rng = rng_;  // the state run_epoch will start from
  const std::vector<std::size_t> order = epoch_order(count, rng);
  const auto bs = std::size_t(std::max(1, opt_.batch_size));
  std::vector<bool> need(count, false);
  for (std::size_t b0 = 0; b0 < count; b0 += bs) {
    const std::size_t n = std::min(bs, count - b0);
    const dist::Share sh = dist::share_of(n, comm_.rank(), comm_.size());
    if (sh.empty()) need[order[b0]] = true;  // the placeholder
    for (std::size_t k = sh.begin; k < sh.end; ++k) need[order[b0 + k]] = true;
  }
  return need;
}

EpochStats Trainer::run_epoch(const std::vector<Sample>& train, const std::vector<Sample>& val,
                              const BatchCallback& on_batch) {
  GATCORE_CHECK(!train.empty(), "Trainer: no training samples");
  GATCORE_CHECK(!swapped_, "Trainer: an epoch started while the model holds the averaged weights");
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t bytes0 = comm_.bytes_sent();
  const double comm0 = comm_.seconds_in_collectives();
  EpochStats st;
  st.epoch = ++epoch_;
  const std::vector<std::size_t> order = epoch_order(train.size(), rng_);
  const auto bs = std::size_t(std::max(1, opt_.batch_size));
  const std::int64_t nb = std::int64_t((train.size() + bs - 1) / bs);
  const std::vector<int> pools = model_.pool_sizes();
  if (comm_.size() > 1) {
    // Every rank starts the epoch from rank 0's model and optimiser state:
    // one copy even after a resume, or on ranks whose CPUs round differently.
    std::vector<Tensor> state;
    for (const auto& p : model_.registry().params) state.push_back(p.var.value());
    for (const auto& b : model_.registry().buffers) state.push_back(b.tensor);
    for (const Tensor& t : adam_.first_moments()) state.push_back(t);
    for (const Tensor& t : adam_.second_moments()) state.push_back(t);
    for (const Tensor& t : average_) state.push_back(t);
    dist::broadcast_tensors(comm_, state);
    for (const auto& p : model_.registry().params) p.var.value().bump_version();
  }
  double sum = 0;
  for (std::int64_t b = 0; b < nb; ++b) {
    std::vector<const Sample*> smp;
    std::vector<std::vector<std::int32_t>> sel;
    for (std::size_t k = std::size_t(b) * bs; k < std::min(train.size(), std::size_t(b + 1) * bs); ++k) {
      const Sample& s = train[order[k]];
      smp.push_back(&s);
      sel.push_back(sample_vertices(s.graph->num_nodes, opt_.sampling, opt_.sample_vertices, rng_));
    }
    const double l = step(smp, sel, pools);
    GATCORE_CHECK(std::isfinite(l), "training diverged at epoch ", epoch_, ", batch ", b + 1, " (loss ", l,
                  "); try a smaller learning rate");
    adam_.step();
    if (!average_.empty()) update_average();
    sum += l;
    st.samples += std::int64_t(smp.size());
    if (on_batch) on_batch(epoch_, b + 1, nb, l);
  }
  st.batches = nb;
  st.train_loss = sum / double(nb);
  if (!val.empty()) {
    AveragedWeightsScope averaged(*this);  // the weights a checkpoint of this epoch holds
    const Evaluation e = validate(val);
    st.val_loss = e.loss;
    st.val_l1 = e.weight_l1;
    st.val_dominant = e.dominant;
  }
  const float metric = float(st.val_loss >= 0 ? st.val_loss : st.train_loss);
  if (opt_.schedule == Schedule::plateau) {
    if (st.val_loss >= 0 && !plateau_.on_validation) {
      // The first validation: training losses are not comparable with it.
      plateau_.on_validation = true;
      plateau_.has_best = false;
      plateau_.bad_epochs = 0;
    }
    if (st.val_loss >= 0 || !plateau_.on_validation) adam_.set_lr(plateau_.step(metric, adam_.lr()));
  } else if (opt_.schedule == Schedule::step && opt_.step_every > 0 && epoch_ % opt_.step_every == 0) {
    adam_.set_lr(std::max(opt_.min_lr, adam_.lr() * opt_.step_gamma));
  }
  st.lr = adam_.lr();
  st.comm_bytes = double(comm_.bytes_sent() - bytes0);
  st.comm_seconds = comm_.seconds_in_collectives() - comm0;
  st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return st;
}

double Trainer::step(const std::vector<const Sample*>& smp, const std::vector<std::vector<std::int32_t>>& sel,
                     const std::vector<int>& pools) {
  ProductPrecisionScope precision(opt_.precision);  // forward and backward products
  adam_.zero_grad();
  if (comm_.size() == 1) {
    Batch batch = make_batch(smp, sel, norm_, pools);
    to_device(batch, model_.device());  // once per batch; nothing else crosses until the loss read
    Var loss = task_loss(model_.config(), model_.forward(batch, true), batch.target);
    backward(loss);
    const double l = to(loss.value(), Device::cpu).at(0, 0);  // the step's one host read
    forget_graphs(batch, model_.device());
    return l;
  }
  // This rank's characters of the batch; their rows within the batch's rows.
  const dist::Share share = dist::share_of(smp.size(), comm_.rank(), comm_.size());
  BatchSplit split;
  split.sum = [this](double* v, std::size_t n) { comm_.sum(v, n); };
  for (std::size_t k = 0; k < smp.size(); ++k) {
    const auto rows = std::int64_t(sel[k].empty() ? smp[k]->graph->num_nodes : std::int64_t(sel[k].size()));
    if (k < share.begin) split.row_begin += rows;
    if (k >= share.begin && k < share.end) split.rows += rows;
    split.global_rows += rows;
  }
  // A batch with fewer characters than ranks: the ranks without one run the
  // first character as a placeholder (split.rows = 0: it adds nothing), so
  // that they take part in every sum of the step.
  const std::size_t b0 = share.empty() ? 0 : share.begin, b1 = share.empty() ? 1 : share.end;
  const std::vector<const Sample*> mine(smp.begin() + std::ptrdiff_t(b0), smp.begin() + std::ptrdiff_t(b1));
  const std::vector<std::vector<std::int32_t>> mine_sel(sel.begin() + std::ptrdiff_t(b0),
                                                        sel.begin() + std::ptrdiff_t(b1));
  Batch batch = make_batch(mine, mine_sel, norm_, pools);
  to_device(batch, model_.device());
  double l = 0;
  {
    BatchSplitScope scope(split);
    // The loss is a mean over the batch's rows: this rank's mean weighted by
    // its share of the rows, so the ranks' gradients add up to the batch's.
    const double w = double(split.rows) / double(split.global_rows);
    Var loss = scale(task_loss(model_.config(), model_.forward(batch, true), batch.target), float(w));
    backward(loss);
    l = to(loss.value(), Device::cpu).at(0, 0);
  }
  forget_graphs(batch, model_.device());
  dist::sum_gradients(comm_, model_.parameters());
  comm_.sum(&l, 1);
  return l;
}

Evaluation Trainer::validate(const std::vector<Sample>& samples) {
  NoGradGuard ng;
  // Sharded by sample (round robin); every sample's figures land in its
  // slots and the slots are summed in sample order, on every rank: the same
  // numbers as one process computes.
  const bool weights = model_.config().task == Task::weights;
  std::vector<double> losses(samples.size(), 0.0), l1(weights ? samples.size() : 0, 0.0),
      dominant(weights ? samples.size() : 0, 0.0);
  for (std::size_t i = std::size_t(comm_.rank()); i < samples.size(); i += std::size_t(comm_.size())) {
    const Sample& s = samples[i];
    Batch b = make_batch({&s}, {{}}, norm_, model_.pool_sizes());
    to_device(b, model_.device());
    const Var pred = model_.forward(b, false);
    losses[i] = to(task_loss(model_.config(), pred, b.target).value(), Device::cpu).at(0, 0);
    if (weights) {
      const Tensor w = top_k_renormalise(to(pred.value(), Device::cpu), kEvaluationInfluences);
      const Tensor t = to(b.target, Device::cpu);
      const bool partial = s.target_mass.defined();
      GATCORE_CHECK(!partial || (s.target_mass.rows() == w.rows() && s.target_mass.cols() == 1), s.name,
                    ": target_mass is ", s.target_mass.rows(), " x ", s.target_mass.cols(), " for ", w.rows(),
                    " vertices");
      GATCORE_CHECK(s.target_dominant.empty() || std::int64_t(s.target_dominant.size()) == w.rows(), s.name,
                    ": target_dominant has ", s.target_dominant.size(), " entries for ", w.rows(), " vertices");
      const auto argmax = [](const Tensor& x, std::int64_t r) {
        std::int64_t best = 0;
        for (std::int64_t c = 1; c < x.cols(); ++c)
          if (x.at(r, c) > x.at(r, best)) best = c;
        return best;
      };
      std::int64_t right = 0;
      double sum = 0;
      for (std::int64_t r = 0; r < w.rows(); ++r) {
        // The truth is t * m over the target's columns and 1 - m elsewhere,
        // where the prediction puts nothing.
        const double m = partial ? double(s.target_mass.at(r, 0)) : 1.0;
        for (std::int64_t c = 0; c < w.cols(); ++c) sum += std::abs(double(w.at(r, c)) - m * double(t.at(r, c)));
        sum += 1.0 - m;
        const std::int64_t truth = s.target_dominant.empty() ? argmax(t, r) : s.target_dominant[std::size_t(r)];
        right += argmax(w, r) == truth;
      }
      l1[i] = w.rows() > 0 ? sum / double(w.rows()) : 0.0;
      dominant[i] = w.rows() > 0 ? double(right) / double(w.rows()) : 0.0;
    }
    forget_graphs(b, model_.device());
  }
  comm_.sum(losses.data(), losses.size());
  if (weights) {
    comm_.sum(l1.data(), l1.size());
    comm_.sum(dominant.data(), dominant.size());
  }
  // Means over the samples, summed in sample order.
  const auto mean = [&](const std::vector<double>& v) {
    double sum = 0;
    for (double x : v) sum += x;
    return samples.empty() ? 0.0 : sum / double(samples.size());
  };
  Evaluation e;
  e.loss = mean(losses);
  if (weights) {
    e.weight_l1 = mean(l1);
    e.dominant = mean(dominant);
  }
  return e;
}

}  // namespace gatcore::models
