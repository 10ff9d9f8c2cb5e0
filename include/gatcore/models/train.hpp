#pragma once
// Training (the train layer): vertex sampling, the Trainer, Adam with the
// papers' schedules, and the training state a checkpoint carries. Batching and
// inference are models/predict.hpp's.
//
// Determinism: given the same seed, samples and options, training is
// bit-reproducible on one machine and build (seeded mt19937_64 with our own
// distributions for initialisation, sampling, shuffling and dropout; every
// kernel reduces in a fixed order: gather-based backward passes, fixed GEMM
// tiling). That holds across OpenMP thread counts too (tested: 1 vs 2). It
// does not hold across SIMD levels (GATCORE_SIMD, different CPUs: FMA and
// vectorised exp/tanh round differently) or compilers.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "gatcore/dist/communicator.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/predict.hpp"
#include "gatcore/models/sample.hpp"
#include "gatcore/optim.hpp"
#include "gatcore/precision.hpp"

namespace gatcore::models {

enum class Sampling {
  full,         // every vertex (inference; tiny meshes)
  consecutive,  // `sample_vertices` consecutive vertex ids from a random start (DenseGATs)
  random,       // `sample_vertices` distinct random vertices (NeuroSkinning)
};
// "full" / "consecutive" / "random" (gat train --sampling, checkpoint metadata "sampling").
const char* sampling_name(Sampling s);
// Throws InvalidArgument naming `name` for anything else.
Sampling sampling_from_name(const std::string& name);
// plateau: ReduceLROnPlateau (DenseGATs' paper); step: x step_gamma every
// step_every epochs (NeuroSkinning's); cosine: the caller sets the rate before
// each epoch from the run's progress (cosine_lr) and the Trainer leaves it
// alone: a time budget (gat train --minutes) knows its end, which the papers'
// epoch-count schedules do not, and ends at a small rate instead of wherever
// the plateau rule happened to be.
enum class Schedule { plateau, step, cosine };
// "plateau" / "step" / "cosine" (gat train --lr-schedule, checkpoint metadata "lr_schedule").
const char* schedule_name(Schedule s);
// Throws InvalidArgument naming `what` and `name` for anything else.
Schedule schedule_from_name(const std::string& name, const char* what = "--lr-schedule");
// Cosine annealing from lr0 (progress 0) to lr_min (progress 1); progress is
// clamped to [0, 1].
float cosine_lr(float lr0, float lr_min, double progress);

struct TrainOptions {
  int batch_size = 8;
  float lr = 1e-3f;
  Sampling sampling = Sampling::consecutive;
  std::int64_t sample_vertices = 1000;
  Schedule schedule = Schedule::plateau;
  float plateau_factor = 0.75f;
  int plateau_patience = 8;
  float min_lr = 5e-7f;
  float step_gamma = 0.99f;
  int step_every = 200;
  std::uint64_t seed = 0;
  // Precision of the training step's large products (linear layers, GAT
  // projections: precision.hpp's ProductPrecisionScope around each step);
  // validation and everything else stay fp32. The Trainer replaces bf16 by
  // fp32 where the model's backend has no bf16 products (see
  // training_precision); options().precision is what runs.
  Precision precision = Precision::fp32;
  // An exponential moving average of the parameters and buffers (Polyak
  // averaging): after every step avg = d * avg + (1 - d) * x, with d = min(decay,
  // (1 + t) / (10 + t)) at step t so that the first steps are not frozen in.
  // Validation and checkpoints then use the averaged weights, which vary less
  // from epoch to epoch than the last step's. 0: off.
  float average_decay = 0.f;

  // The paper settings for a model: DenseGATs family and Ori.GAT: batch 8,
  // 1000 consecutive vertices, ReduceLROnPlateau; NeuroSkinning family: batch
  // 12, 2048 random vertices, ×0.99 every 200 epochs.
  static TrainOptions defaults_for(const ModelConfig& cfg);
};

// ReduceLROnPlateau (mode min, relative threshold 1e-4, like PyTorch's default).
// Once it has seen a validation loss it steps only on validation losses:
// epochs without validation (gat train --val-every K) leave it alone, so it
// never compares a training loss with a validation best.
struct PlateauScheduler {
  float factor = 0.75f, min_lr = 5e-7f;
  int patience = 8;
  float best = 0.f;
  bool has_best = false;
  bool on_validation = false;  // the metric so far has been the validation loss
  int bad_epochs = 0;
  float step(float metric, float lr);  // returns the new lr
};

// The precision a training step on device `d` runs for `requested`: bf16
// needs that backend's bf16 products (the CPU backend: AVX512_BF16), else
// fp32, with `why` (if given) set to a one-line reason; empty when granted.
Precision training_precision(Precision requested, Device d, std::string* why = nullptr);

// Vertices of `n` chosen for one training sample.
std::vector<std::int32_t> sample_vertices(std::int64_t n, Sampling s, std::int64_t k, nn::Rng& rng);

struct EpochStats {
  int epoch = 0;
  double train_loss = 0, val_loss = -1;  // val_loss < 0: no validation set
  // Skin-weight models: validation's mean per-vertex L1 of the top-4
  // renormalised weights (Evaluation::weight_l1); -1 otherwise.
  double val_l1 = -1;
  double val_dominant = -1;  // and the fraction of vertices whose dominant bone is right (Evaluation::dominant)
  float lr = 0;
  std::int64_t batches = 0, samples = 0;
  double seconds = 0;
  // Data parallel: this rank's bytes sent and seconds spent in collectives
  // during the epoch (0 in one process).
  double comm_bytes = 0, comm_seconds = 0;
};

// What validation measures. For skin-weight models the loss (KL divergence
// of the predicted distribution) is not what users judge weights by: late in
// training it keeps falling while the weights' L1 rises (docs/experiments/skin-weights.md,
// "Which checkpoint to evaluate"), so the L1 is measured too.
struct Evaluation {
  double loss = 0;
  // Task::weights: per sample the mean over its vertices of
  // sum_j |w_j - t_j|, averaged over the samples (as `gat eval`'s overall
  // row averages its characters), w the prediction kept to its kEvaluationInfluences
  // largest weights and renormalised (what predict_skin_weights gives by
  // default), t the sample's target (where the sample has a target_mass,
  // the truth over the target's columns is t times it and the rest counts as
  // error: skinweights-any's L1 is over the character's joints, as gat
  // eval's). -1 for displacements.
  double weight_l1 = -1;
  // Task::weights: per sample the fraction of vertices whose largest
  // predicted weight is on the artist's dominant joint (Sample::
  // target_dominant, else the largest target column; ties: the first
  // column), averaged over the samples as weight_l1. -1 for displacements.
  double dominant = -1;
};
inline constexpr int kEvaluationInfluences = 4;

// Called after every batch: (epoch, batch index, batches in epoch, loss).
using BatchCallback = std::function<void(int, std::int64_t, std::int64_t, double)>;

// Trains where the model's parameters are (Model::to before constructing the
// Trainer): each batch is built on the host and moved to the device once;
// the loss read is the step's only transfer back.
//
// Data parallel (`comm` of more than one rank, e.g. dist::world() under
// mpirun): every rank draws the same batches (order and vertex selections)
// as one process would, builds only its share of each batch's characters
// (dist::share_of), runs forward and backward on it with BatchNorm
// statistics summed over the ranks (SyncBatchNorm, batch_split.hpp) and
// Dropout masks cut from the whole batch's stream, and the gradients are
// summed over the ranks (one flat buffer, a fixed order) before the same
// Adam step on every rank. Validation is sharded by sample and gathered
// exactly. Each epoch starts from rank 0's parameters and moments.
//
// What equals one process, and why not everything bit for bit: for a fixed
// N a run is bit-reproducible, and the sharded validation loss of a model is
// the one-process number bitwise. The training step is not: a rank's
// backward sums its own rows' contributions to each weight gradient inside
// its GEMMs, so N groups the float sums differently (and BatchNorm's double
// statistics likewise). Bitwise equality would need every parameter-gradient
// kernel to keep per-character partial sums and the ranks to exchange them
// all (batch size × the gradient volume). Measured instead (tests/dist/):
// step 1's summed gradient agrees to < 1e-6 of its largest value, step
// losses to < 1e-5 relative; Adam turns rounding-level gradients (a bias
// right before a BatchNorm, whose gradient is zero but for rounding) into
// ~lr steps in any run, so checkpoints are compared on the parameters that
// carry a gradient: within 0.25 lr after 3 steps (measured <= 0.05 lr).
class Trainer {
 public:
  Trainer(Model& model, TrainOptions opt, Normaliser norm, dist::Communicator& comm = dist::world());
  // One pass over `train` in a seeded random order; validation (full meshes,
  // eval mode) if `val` is non-empty; then the schedule's lr update.
  EpochStats run_epoch(const std::vector<Sample>& train, const std::vector<Sample>& val = {},
                       const BatchCallback& on_batch = {});
  // Mean loss over full meshes in eval mode.
  double evaluate(const std::vector<Sample>& samples) { return validate(samples).loss; }
  // The mean loss and, for skin weights, the weights' L1 (Evaluation).
  Evaluation validate(const std::vector<Sample>& samples);
  // Which of `count` training samples the next run_epoch makes this rank
  // build a batch from (its shares, and the first sample of a batch it has
  // no share of); all of them in one process. The others may be stubs that
  // only carry their graph's vertex count (character::training_samples'
  // `build`): every rank draws every sample's vertex selection.
  std::vector<bool> samples_needed(std::size_t count) const;

  Model& model() { return model_; }
  Adam& optimiser() { return adam_; }
  const Normaliser& normaliser() const { return norm_; }
  const TrainOptions& options() const { return opt_; }
  int epoch() const { return epoch_; }
  nn::Rng& rng() { return rng_; }
  PlateauScheduler& plateau() { return plateau_; }
  dist::Communicator& communicator() { return comm_; }
  // Restores the resumable state (checkpoints).
  void set_epoch(int e) { epoch_ = e; }

  // options().average_decay > 0: the running average of the parameters and
  // of the buffers (BatchNorm's running statistics must match the averaged
  // weights they normalise): one tensor per parameter, then one per buffer,
  // in registry order, on the model's device.
  bool averaging() const { return !average_.empty(); }
  std::vector<Tensor>& averaged() { return average_; }
  const std::vector<Tensor>& averaged() const { return average_; }
  // Exchanges the model's parameters and buffers with their running average (a no-op
  // without averaging): validation and checkpoints run between two calls.
  void swap_averaged();

 private:
  // One optimiser step on the global batch `smp` / `sel`; returns its loss.
  double step(const std::vector<const Sample*>& smp, const std::vector<std::vector<std::int32_t>>& sel,
              const std::vector<int>& pools);
  Model& model_;
  dist::Communicator& comm_;
  TrainOptions opt_;
  Normaliser norm_;
  Adam adam_;
  nn::Rng rng_;
  PlateauScheduler plateau_;
  int epoch_ = 0;
  std::vector<Tensor> average_;  // empty: no averaging
  bool swapped_ = false;         // the model holds the average now
  void update_average();
  std::vector<Tensor> averaged_tensors() const;  // the model's tensors average_ follows
};

// The model holds its trainer's averaged weights for the scope's life (both
// no-ops without averaging).
class AveragedWeightsScope {
 public:
  explicit AveragedWeightsScope(Trainer& t) : t_(t) { t_.swap_averaged(); }
  ~AveragedWeightsScope() { t_.swap_averaged(); }
  AveragedWeightsScope(const AveragedWeightsScope&) = delete;
  AveragedWeightsScope& operator=(const AveragedWeightsScope&) = delete;

 private:
  Trainer& t_;
};

// save_checkpoint (checkpoint.hpp) with, when `trainer` is given, the state
// to resume training: Adam moments ("optim.m.<param>", "optim.v.<param>"),
// epoch, lr, adam_steps, rng and the plateau scheduler's state. A trainer
// that averages writes the averaged weights and buffers as the model (what a
// user runs) and the last step's as "optim.raw.<name>" (what training goes
// on from). The model may
// live on any device (tensors are downloaded before writing).
void save_checkpoint(const std::string& path, const Model& model, const Normaliser& norm, const Trainer* trainer,
                     const std::map<std::string, std::string>& extra = {});

// Restores optimiser moments, epoch, lr, RNG and scheduler state saved with
// the trainer (the trainer must wrap the model loaded from the same file).
// Where the file holds "optim.raw.<name>", the model goes on from those and
// an averaging trainer's average from the file's model weights; an averaging
// trainer resuming a file without them starts its average there.
void restore_training_state(const CheckpointFile& f, Trainer& trainer, const std::string& path = "checkpoint");

// How far the trainer that saved a checkpoint got, for people reading the
// file (gat info): the epoch, learning rate and Adam steps save_checkpoint
// records, and whether the optimiser's moments are there to resume from. A
// model saved without a trainer reads as epoch 0, no rate, 0 steps. Values
// are parsed strictly (CheckpointError naming `path` and the key).
struct TrainingProgress {
  int epoch = 0;
  double lr = -1;  // < 0: not recorded
  std::int64_t adam_steps = 0;
  bool resumable = false;  // the Adam moments are saved
  double average_decay = 0;  // > 0: the model is a moving average of the weights, with this decay
};
TrainingProgress read_training_progress(const CheckpointFile& f, const std::string& path = "checkpoint");

}  // namespace gatcore::models
