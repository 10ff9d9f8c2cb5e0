// `gat train`: trains any model by name, with a progress line,
// validation every epoch, a resumable checkpoint every epoch and Ctrl-C
// handling. It trains on a dataset of the character pipeline (--data, see
// character/data/training_data.hpp) or on the embedded tube character
// (character/data/tube_data.hpp).

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <omp.h>

#include "cli_util.hpp"
#include "gatcore/character/data/tube_data.hpp"
#include "commands.hpp"
#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/dataset_model_description.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/viz/loss_curve.hpp"
#include "gatcore/models/model_kind.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "progress.hpp"
#include "gatcore/dist/communicator.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/models/linear_skip.hpp"
#include "gatcore/train/training_run.hpp"
#include "gatcore/vulkan.hpp"

using namespace gatcore;
using namespace gatcore::models;
using gatcore::character::LossRecord;

namespace {

volatile std::sig_atomic_t g_stop = 0;
// First Ctrl-C: finish the epoch, write its checkpoint, stop. Second: quit
// now (the last complete checkpoint is intact: writes are atomic).
void on_sigint(int) {
  if (g_stop) std::_Exit(130);
  g_stop = 1;
}

struct TrainArgs {
  std::string model_name = "densegats", out = "model.gcm", resume, init, data, task, curve, loss, joint_columns, keep_best,
              sampling, precision, lr_schedule, keep_best_by;
  bool lr_set = false;  // --lr given (a resumed run otherwise continues at the checkpoint's rate)
  std::vector<std::string> architecture_flags;  // given flags that --init takes from its checkpoint instead
  long epochs = 10, seed = 0, batch = 0, samples = 64;
  float lr = 1e-3f;
  double minutes = 0;  // 0: no time budget
  double average_decay = -1;  // < 0: not given
  long val_every = 1, sample_vertices = 0;
  std::vector<std::int64_t> pair_scorer;
  double classifier_dropout = -1;  // < 0: not given
  std::string world_columns;  // skinweights-any: use | ignore; empty: the default (or a resumed checkpoint's)
  bool linear_skip = false;
  gat::CommonOptions common;
};

// Fault injection for the data-parallel tests (tests/dist/): GAT_TRAIN_FAULT=R:S
// makes rank R kill itself (SIGKILL, no clean-up) once it has taken S optimiser steps.
void maybe_inject_fault(int rank, long steps) {
  static const char* spec = std::getenv("GAT_TRAIN_FAULT");
  int r = -1;
  long s = -1;
  if (spec && std::sscanf(spec, "%d:%ld", &r, &s) == 2 && r == rank && steps >= s) {
    std::fprintf(stderr, "gat train: rank %d: GAT_TRAIN_FAULT: killing myself after step %ld\n", rank, steps);
    std::fflush(nullptr);
    std::raise(SIGKILL);
  }
}

int run_train(TrainArgs a);

}  // namespace

gat::Runner gat::setup_train(CLI::App& gat) {
  auto a = std::make_shared<TrainArgs>();
  CLI::App& c = add_command(gat, "train", "train a model by name (densegats, neuroskinning, ...)");
  set_details(c, "Trains a model and writes a resumable checkpoint (safetensors + metadata) after every epoch.\n"
                "Ctrl-C stops after the current epoch's checkpoint is written.");
  // The list comes from the library's kinds, so a new model cannot be missing from the help.
  std::string kinds;
  for (const models::ModelKind k : models::all_model_kinds())
    kinds += std::string(kinds.empty() ? "" : ", ") + models::model_kind_name(k) +
             (k == models::ModelKind::densegats ? " (default)" : "");
  c.add_option("--model", a->model_name, kinds + "; paper settings");
  c.add_option("--task", a->task,
               "weights or displacement (default: the model's paper task; e.g. --model neuroskinning --task "
               "displacement is DenseGATs' comparison)")
      ->check(one_of({"weights", "displacement"}));
  c.add_option("--loss", a->loss,
               "displacement models: mse (the paper's) or l1 (mean absolute error: keeps LBS where unsure; closer to "
               "the mean vertex error gat eval reports). Skin-weight models: kl (NeuroSkinning's) or l1 (the L1 over a "
               "vertex's bones gat eval reports: keeps the likely bones where unsure instead of spreading weight). "
               "Default: the model's (l1 for skinweights-any, kl for the NeuroSkinning models, mse otherwise)")
      ->check(one_of({"mse", "l1", "kl"}));
  c.add_flag("--linear-skip", a->linear_skip,
             "displacement models (densegats family, origat): add a per-vertex linear map of the input columns to the output, set to the "
             "least-squares fit of the training targets before the first epoch (the graph network learns the "
             "residual; recorded in the checkpoint's configuration; not the paper's architecture)");
  c.add_option("--joint-columns", a->joint_columns,
               "displacement models' joint features: bones (default, the paper: distance to each bone of the "
               "dataset's super skeleton, matched by name) or nearest:K (distances to each vertex's K nearest "
               "joints, nearest first: the model then works on any skeleton, no joint names; e.g. nearest:4)");
  add_out(c, a->out, "checkpoint path")->capture_default_str();
  c.add_option("--epochs", a->epochs, "epochs to train, in total when resuming")
      ->check(int_in(1, 10000000))->capture_default_str();
  c.add_option("--resume", a->resume,
               "continue from a checkpoint written by gat train (model, data, seed and batch size from the file)");
  c.add_option("--init", a->init,
               "fine-tune: start from a checkpoint's weights and input statistics (its model, loss, linear skip and "
               "joint columns) on --data, which may be another dataset with the same input columns (e.g. your own "
               "characters and targets, or other poses); a new optimiser from epoch 0 at --lr")
      ->excludes("--resume");
  add_seed(c, a->seed, "initialisation, sampling and data seed");
  add_threads(c, a->common);
  c.add_option("--batch", a->batch, "characters per batch (default: paper, 8 or 12)")->check(int_in(1, 4096));
  c.add_option("--lr", a->lr,
               "initial learning rate (on --resume: replaces the checkpoint's current rate; without it the run "
               "continues at that rate)")
      ->check(positive_number())->capture_default_str();
  c.add_option("--lr-schedule", a->lr_schedule,
               "plateau (the DenseGATs family's default: x0.75 after 8 validations without improvement), step "
               "(NeuroSkinning's default: x0.99 every 200 epochs) or cosine (from the initial rate down to 5e-7 "
               "over this run's --minutes, else over its epochs: a time-budgeted run ends annealed); default of "
               "a resumed run: the checkpoint's")
      ->check(CLI::IsMember({"plateau", "step", "cosine"}));
  c.add_option("--average-decay", a->average_decay,
               "keep an exponential moving average of the weights, decay D per step (e.g. 0.98): validation, "
               "--keep-best and the written models use the averaged weights, which swing less from epoch to epoch; "
               "0: off (the default); default of a resumed run: the checkpoint's")
      ->check(CLI::Range(0.0, 0.999999));
  c.add_option("--minutes", a->minutes,
               "time budget: no new epoch starts once M minutes of training have passed (the epoch running then "
               "finishes; --epochs still caps it)")
      ->check(positive_number());
  c.add_option("--samples", a->samples,
               "training samples of the embedded data (default 64; 8 more validate); with --data: poses per "
               "character and epoch (default: all of the dataset's)")
      ->check(int_in(1, 1000000));
  c.add_option("--data", a->data,
               "a dataset written by gat dataset build: trains on its training characters, validates on its "
               "validation characters (bones: the dataset's super skeleton)");
  add_device(c, a->common);
  c.add_option("--loss-curve", a->curve,
               "the loss curve picture, rewritten after every epoch (default: the checkpoint's path with .loss.png "
               "for its extension); the losses also go to its .csv");
  c.add_option("--val-every", a->val_every, "validate every K-th epoch and after the last one")
      ->check(int_in(1, 1000000))->capture_default_str();
  c.add_option("--pair-scorer", a->pair_scorer,
               "skinweights-any: score every (vertex, candidate bone) with one shared MLP of these hidden widths "
               "(e.g. 64) from the vertex's context and the pair's columns, instead of a classifier output column "
               "per candidate slot")
      ->delimiter(',')->check(int_in(1, 4096));
  c.add_option("--classifier-dropout", a->classifier_dropout,
               "the NeuroSkinning family (neuroskinning, skinweights-any): drop each hidden unit of the classifier "
               "with probability P while training (e.g. 0.5), a regulariser against learning the training "
               "families' conventions; recorded in the checkpoint's configuration (default: skinweights-any 0.5, "
               "the NeuroSkinning models 0, the paper)")
      ->check(CLI::Range(0.0, 0.95));
  c.add_option("--world-columns", a->world_columns,
               "skinweights-any: the vertex's world-frame rest position and normal, the only inputs not measured "
               "from the character's own bones: ignore (default; they normalise to 0, so the model cannot learn where "
               "a humanoid keeps its head and apply it to a spider) or use (the models before 2026-12-04). Recorded "
               "in the checkpoint's normaliser; a resumed or fine-tuned model keeps its own")
      ->check(CLI::IsMember({"use", "ignore"}));
  c.add_option("--keep-best", a->keep_best,
               "also write the checkpoint of the epoch with the best validation figure so far (--keep-best-by) to "
               "this path (--out stays the latest epoch, to resume from; a resumed run continues from the loss "
               "history's best)");
  c.add_option("--keep-best-by", a->keep_best_by,
               "what --keep-best minimises: the validation loss, or (skin-weight models) the validation L1 of the "
               "top-4 weights, what users judge weights by (the loss, over every candidate bone before the top-4 cut, "
               "can keep falling while the weights get worse). Default: l1 for skin-weight models, loss otherwise")
      ->check(CLI::IsMember({"loss", "l1"}));
  c.add_option("--sampling", a->sampling,
               "which vertices of a character a training sample takes: random (NeuroSkinning's), consecutive "
               "(a window of vertex ids, DenseGATs'; default of the other models) or full (every vertex: the mesh "
               "graph and the per-character max pool see what they see at inference; --sample-vertices unused)")
      ->check(CLI::IsMember({"random", "consecutive", "full"}));
  c.add_option("--precision", a->precision,
               "arithmetic of the training step's large products (linear layers, GAT projections): fp32 (default), "
               "or bf16 (operands rounded to bfloat16, fp32 sums; about twice the product rate on CPUs with "
               "AVX512_BF16, fp32 with a message elsewhere). Weights, optimiser, losses, BatchNorm and validation "
               "stay fp32; the checkpoint records what ran (default of a resumed run: the checkpoint's)")
      ->check(CLI::IsMember({"fp32", "bf16"}));
  c.add_option("--sample-vertices", a->sample_vertices, "vertices per training sample (default: paper, 1000 or 2048)")
      ->check(int_in(1, 100000000));
  add_quiet(c, a->common);
  c.footer("Without --data the embedded tube character is used: displacement models learn the correction of LBS in "
           "random bend/twist poses; skin-weight models learn the two-bone weights of tubes of varying resolution.");
  return [a, &c] {
    TrainArgs args = *a;
    if (!c.count("--samples")) args.samples = -1;  // not given: the source's default
    args.lr_set = c.count("--lr") > 0;
    for (const char* f : {"--model", "--task", "--loss", "--linear-skip", "--joint-columns", "--pair-scorer",
                          "--classifier-dropout"})
      if (c.count(f)) args.architecture_flags.push_back(f);
    return run_train(std::move(args));
  };
}

namespace {

int run_train(TrainArgs a) {
  std::string model_name = a.model_name, out = a.out, resume = a.resume, init = a.init, data = a.data, task = a.task,
              curve = a.curve, loss = a.loss, joint_columns = a.joint_columns, keep_best = a.keep_best,
              keep_best_by = a.keep_best_by;
  long epochs = a.epochs, seed = a.seed, batch = a.batch, samples = a.samples < 0 ? 64 : a.samples;
  const bool samples_set = a.samples >= 0;
  const float lr = a.lr;
  const double minutes = a.minutes;
  long val_every = a.val_every, sample_vertices = a.sample_vertices;
  const bool quiet = a.common.quiet;
  const bool linear_skip = a.linear_skip;
  gat::apply_threads(a.common);
  if (curve.empty()) curve = gatcore::character::default_curve_path(out);
  // Before any training: a curve that cannot be written would stop the run.
  if (const auto dir = std::filesystem::path(curve).parent_path(); !dir.empty() && !std::filesystem::is_directory(dir)) {
    std::fprintf(stderr, "gat train: --loss-curve %s: the directory %s does not exist\n", curve.c_str(),
                 dir.string().c_str());
    return 2;
  }
  if (!keep_best.empty() && std::filesystem::absolute(keep_best) == std::filesystem::absolute(out)) {
    std::fprintf(stderr, "gat train: --keep-best %s is the --out path; give the best epoch its own file\n",
                 keep_best.c_str());
    return 2;
  }
  if (const auto dir = std::filesystem::path(keep_best).parent_path();
      !keep_best.empty() && !dir.empty() && !std::filesystem::is_directory(dir)) {
    std::fprintf(stderr, "gat train: --keep-best %s: the directory %s does not exist\n", keep_best.c_str(),
                 dir.string().c_str());
    return 2;
  }
  const Device dev = gat::device_from_flag(a.common.device, "train");

  train::RunRequest request{resume, init, data, loss, linear_skip, a.pair_scorer, float(a.classifier_dropout),
                            a.world_columns, a.architecture_flags, keep_best_by};
  const auto refuse = [](const std::string& why) {
    std::fprintf(stderr, "gat train: %s\n", why.c_str());
    return 2;
  };
  if (const std::string why = train::check_request(request); !why.empty()) return refuse(why);
  // The checkpoint the model comes from: a resumed run's or a fine-tuned one's.
  const std::string from = resume.empty() ? init : resume;
  std::unique_ptr<Model> model;
  Normaliser norm;
  LoadedModel loaded;
  if (!from.empty()) {
    gat::Activity reading("reading the checkpoint " + from);
    loaded = load_checkpoint(from);
    model = std::move(loaded.model);
    norm = loaded.norm;
  }
  if (!resume.empty()) {
    // The run's data and batching come from the checkpoint, so the resumed
    // run continues exactly where the interrupted one stopped.
    const train::RunSettings s = train::resumed_settings(
        loaded.file, resume, {seed, samples, batch, sample_vertices, a.sampling, a.precision, a.lr_schedule,
                                  a.average_decay});
    seed = s.seed, samples = s.samples, batch = s.batch, sample_vertices = s.sample_vertices;
    a.sampling = s.sampling, a.precision = s.precision, a.lr_schedule = s.lr_schedule;
    a.average_decay = s.average_decay;
    const std::string trained_on = character::read_model_description(loaded.file, resume).data_path;
    if (const std::string why = train::check_resumed_data(resume, trained_on, data); !why.empty()) return refuse(why);
    if (data.empty()) data = trained_on;
    request.data = data;
  }
  std::unique_ptr<character::TrainingData> td;
  if (!data.empty()) {
    {
      gat::Progress loading("preparing the characters of " + data, 0, "characters", quiet);
      td = std::make_unique<character::TrainingData>(character::load_training_data(data, loading.callback()));
    }
    if (resume.empty() && !samples_set) samples = 0;
    if (from.empty()) td->nearest_joints = character::parse_joint_columns(joint_columns, "--joint-columns");
    if (!from.empty()) {
      const character::ModelDescription trained = character::read_model_description(loaded.file, from);
      td->nearest_joints = trained.nearest_joints;
      const int asked = joint_columns.empty() ? -1 : character::parse_joint_columns(joint_columns, "--joint-columns");
      if (const std::string why = character::check_checkpoint_dataset(*td, data, trained, resume, from, asked);
          !why.empty())
        return refuse(why);
    }
    request.nearest_joint_columns = td->nearest_joints > 0;
  }
  if (from.empty()) {
    ModelConfig cfg = ModelConfig::defaults(model_name, character::kTubeFeatures);
    if (!task.empty()) cfg.task = task == "weights" ? Task::weights : Task::displacement;
    if (const std::string why = train::check_new_model_options(cfg, request); !why.empty()) return refuse(why);
    if (td) cfg.in_dim = td->feature_dim(cfg.task);
    cfg.out_dim = cfg.task == Task::weights ? (td ? td->super.num_bones() : character::kTubeBones) : 3;
    if (any_skeleton(cfg.kind())) {  // its columns are each vertex's own nearest bones, not the super skeleton
      cfg.in_dim = character::bone_candidate_feature_dim(character::kDefaultCandidates);
      cfg.out_dim = character::kDefaultCandidates;
      cfg.pair_features = character::kPairFeatures;
    }
    train::apply_architecture_options(cfg, request);
    model = make_model(cfg, std::uint64_t(seed));
  } else if (const std::string why = train::check_checkpoint_architecture(model->config(), request); !why.empty()) {
    return refuse(why);
  }
  const ModelConfig& cfg = model->config();
  // Before any sample is built: --keep-best's figure (the L1 only exists for skin weights).
  std::string keep_best_refusal;
  keep_best_by = train::keep_best_figure(cfg, request, &keep_best_refusal);
  if (!keep_best_refusal.empty()) return refuse(keep_best_refusal);
  const bool any_skeleton = models::any_skeleton(cfg.kind());
  if (td && !any_skeleton) {
    GATCORE_CHECK(cfg.in_dim == td->feature_dim(cfg.task) &&
                      (cfg.task != Task::weights || cfg.out_dim == td->super.num_bones()),
                  "model '", from, "' takes ", cfg.in_dim, " features / ", cfg.out_dim, " outputs; dataset ", data,
                  " has ", td->feature_dim(cfg.task), " features over ", td->super.num_bones(), " bones");
  }
  int geodesic_k = 1;
  for (int k : model->pool_sizes()) geodesic_k = std::max(geodesic_k, k);
  const auto data_samples = [&](character::DatasetPart part, int epoch, const character::SampleFilter& build = {}) {
    if (any_skeleton) return character::bone_candidate_samples(*td, part, int(cfg.out_dim), character::prior_bone_heat(cfg));
    gat::Progress making(std::string("making ") + (part == character::DatasetPart::train ? "training" : "validation") +
                             " samples",
                         0, "samples", quiet);
    return character::training_samples(*td, cfg.task, part, epoch, geodesic_k, int(samples), build, making.callback());
  };
  std::vector<Sample> train = td ? data_samples(character::DatasetPart::train, 0)
                                 : character::tube_samples(cfg.task, int(samples), std::uint64_t(seed) * 2 + 1);
  const std::vector<Sample> val = td ? data_samples(character::DatasetPart::validation, 0)
                                     : character::tube_samples(cfg.task, 8, std::uint64_t(seed) * 2 + 2);
  if (train.empty()) {
    std::fprintf(stderr, "gat train: %s has no training samples\n", data.c_str());
    return 2;
  }
  if (!keep_best.empty() && val.empty()) {
    std::fprintf(stderr, "gat train: --keep-best needs validation samples; %s has none\n",
                 data.empty() ? "the embedded data" : data.c_str());
    return 2;
  }
  // A fine-tuned model keeps the statistics its weights were trained with
  // (and its linear skip, trained along).
  if (from.empty()) norm = Normaliser::fit(train, cfg.task == Task::displacement);
  // A new skinweights-any model ignores the world-frame columns unless told to
  // use them; a checkpoint's normaliser already says which it does.
  if (any_skeleton && from.empty() && a.world_columns != "use") character::ignore_world_columns(norm);
  if (const std::string why = train::check_world_columns(cfg, request, !from.empty(),
                                                          any_skeleton && character::ignores_world_columns(norm));
      !why.empty())
    return refuse(why);
  if (from.empty() && cfg.linear_skip) {
    const LinearMap f = fit_linear_skip(*model, train, norm);
    if (!quiet)
      std::printf("linear skip: least-squares fit on %lld training vertices, MSE %.6f (predicting zero: %.6f)\n",
                  static_cast<long long>(f.rows), f.mse_after, f.mse_before);
  }
  TrainOptions opt = TrainOptions::defaults_for(cfg);
  opt.seed = std::uint64_t(seed);
  opt.lr = lr;
  if (batch > 0) opt.batch_size = int(batch);
  if (sample_vertices > 0) opt.sample_vertices = sample_vertices;
  if (!a.sampling.empty())
    opt.sampling = sampling_from_name(a.sampling);
  if (!a.precision.empty()) opt.precision = parse_precision(a.precision, "--precision");
  if (!a.lr_schedule.empty()) opt.schedule = schedule_from_name(a.lr_schedule);
  if (a.average_decay > 0) opt.average_decay = float(a.average_decay);
  // Parameters are drawn (or loaded) on the CPU and moved before the
  // optimiser allocates its moments next to them.
  model->to(dev);
  // Under mpirun / srun: data parallel over the launched processes (rank 0
  // prints and writes the checkpoints); else one process, as always.
  dist::Communicator& comm = dist::world();
  const bool root = comm.rank() == 0;
  Trainer trainer(*model, opt, norm, comm);
  if (!resume.empty()) {
    restore_training_state(loaded.file, trainer, resume);
    if (a.lr_set) {
      if (root)
        std::printf("learning rate %g from --lr (the checkpoint was at %g)\n", double(lr),
                    double(trainer.optimiser().lr()));
      trainer.optimiser().set_lr(lr);
    }
  }
  // cosine: this run anneals from the rate it starts at (--lr, or a resumed
  // checkpoint's) to min_lr over its own budget.
  const float lr_start = trainer.optimiser().lr();
  // bf16 where the backend cannot: fp32, said once (the Trainer already runs fp32).
  std::string precision_why;
  training_precision(opt.precision, dev, &precision_why);
  if (root && !precision_why.empty()) std::fprintf(stderr, "gat train: --precision bf16: %s\n", precision_why.c_str());

  const std::string source = td ? "dataset " + data + " (" + std::to_string(td->super.num_bones()) + " bones)"
                                : std::string("embedded tube data");
  const std::string task_text = std::string(task_name(cfg.task)) + ", " + loss_name(cfg) + " loss";
  if (root)
    std::printf("gat train: %s (%s), %lld parameters, %s: %zu training / %zu validation samples, "
                "batch %d, %d threads, device %s%s%s\n",
                cfg.name.c_str(), task_text.c_str(), static_cast<long long>(model->registry().num_parameters()),
                source.c_str(), train.size(), val.size(), opt.batch_size, omp_get_max_threads(),
                dev == Device::vulkan ? vulkan::current_device().name.c_str() : "cpu",
                comm.size() > 1 ? (", " + std::to_string(comm.size()) + " MPI ranks (data parallel)").c_str() : "",
                trainer.options().precision == Precision::bf16 ? ", bf16 products" : "");
  // The checkpoint's metadata: the run (training_run.hpp) and what a character command
  // (predict-weights, deform) needs to apply the model (model_description.hpp).
  train::RunRecord run;
  run.seed = seed, run.samples = samples, run.batch = opt.batch_size, run.sample_vertices = opt.sample_vertices;
  run.sampling = opt.sampling, run.schedule = opt.schedule;
  run.precision = trainer.options().precision, run.precision_requested = opt.precision;
  if (td) train::record_init(run, init, init.empty() ? nullptr : &loaded.file, resume.empty() ? nullptr : &loaded.file);
  character::ModelDescription description;
  if (td) {
    description = character::describe_dataset_model(*td, data, cfg, norm);
  } else {
    description.skeleton = character::tube_bone_names();
  }
  const auto metadata = [&] {
    std::map<std::string, std::string> md = train::training_run_metadata(run);
    md.merge(character::model_description_metadata(description));
    return md;
  };
  std::vector<LossRecord> history;
  if (!resume.empty()) {
    const std::string h = train::read_run_record(loaded.file, resume).loss_history;
    if (!h.empty()) history = gatcore::character::parse_history(h, resume);
    std::erase_if(history, [&](const LossRecord& r) { return r.epoch > trainer.epoch(); });
  }
  // --keep-best: the lowest validation loss (or L1) so far, a resumed run's
  // history included (an older checkpoint's history has no L1: it starts afresh).
  const bool by_l1 = keep_best_by == "l1";
  const auto figure = [&](double val, double val_l1) { return by_l1 ? val_l1 : val; };
  const char* figure_name = by_l1 ? "validation L1" : "validation loss";
  double best_val = -1;
  int best_epoch = 0;
  for (const LossRecord& r : history)
    if (const double f = figure(r.val, r.val_l1); f >= 0 && (best_val < 0 || f < best_val))
      best_val = f, best_epoch = r.epoch;
  if (trainer.epoch() >= epochs) {
    if (root) std::printf("the checkpoint has already trained %d of %ld epochs; nothing to do\n", trainer.epoch(), epochs);
    return 0;
  }
  const bool tty = root && gat::Progress::enabled(quiet);
  std::signal(SIGINT, on_sigint);
  if (tty) std::fprintf(stderr, "(Ctrl-C stops after the current epoch's checkpoint; twice quits at once)\n");
  const auto t0 = std::chrono::steady_clock::now();
  const int first = trainer.epoch();
  gat::Activity doing("training " + cfg.name);
  while (trainer.epoch() < epochs) {
    // Displacement datasets: the random poses and windows of this epoch
    // (deterministic per seed and epoch, so a resumed run sees the same).
    // Data parallel: each rank builds only the samples of its shares.
    if (td && cfg.task == Task::displacement && trainer.epoch() > 0) {
      std::vector<bool> need;
      train = data_samples(character::DatasetPart::train, trainer.epoch(), [&](std::size_t i, std::size_t n) {
        if (need.size() != n) need = trainer.samples_needed(n);
        return bool(need[i]);
      });
    }
    const auto te = std::chrono::steady_clock::now();
    const auto progress = [&](int e, std::int64_t b, std::int64_t nb, double loss) {
      maybe_inject_fault(comm.rank(), trainer.optimiser().steps());
      if (!tty) return;
      const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - te).count();
      const double sps = double(std::min<std::int64_t>(b * opt.batch_size, std::int64_t(train.size()))) / std::max(el, 1e-9);
      const double done = double(e - 1 - first) + double(b) / double(nb);
      const double tot = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double eta = done > 0 ? tot / done * (double(epochs - first) - done) : 0;
      std::fprintf(stderr, "\repoch %d/%ld  batch %lld/%lld  loss %.5f  lr %.3g  %.1f samples/s  ETA %s ", e, epochs,
                   static_cast<long long>(b), static_cast<long long>(nb), loss, trainer.optimiser().lr(), sps,
                   gat::hms(eta).c_str());
      std::fflush(stderr);
    };
    if (opt.schedule == Schedule::cosine) {
      // Progress through this run's budget, rank 0's clock: every rank must
      // step with the same rate.
      double p = minutes > 0 ? std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
                                   (minutes * 60.0)
                             : double(trainer.epoch() - first) / double(std::max<long>(1, epochs - first));
      comm.broadcast(&p, sizeof p, 0);
      trainer.optimiser().set_lr(cosine_lr(lr_start, opt.min_lr, p));
    }
    const bool last = trainer.epoch() + 1 >= epochs;
    const bool validate = last || (trainer.epoch() + 1) % val_every == 0;
    const EpochStats st = trainer.run_epoch(train, validate ? val : std::vector<Sample>{}, progress);
    history.push_back({st.epoch, st.train_loss, st.val_loss, double(st.lr), st.seconds, st.val_l1, st.val_dominant});
    run.loss_history = gatcore::character::format_history(history);
    const std::map<std::string, std::string> extra = metadata();
    if (root) {  // every rank holds the same model; one writes it
      save_checkpoint(out, *model, norm, &trainer, extra);
      gatcore::character::write_loss_outputs(history, curve);
    }
    const double fig = figure(st.val_loss, st.val_l1);
    const bool improved = !keep_best.empty() && fig >= 0 && (best_val < 0 || fig < best_val);
    if (improved) {
      best_val = fig;
      best_epoch = st.epoch;
      if (root) save_checkpoint(keep_best, *model, norm, &trainer, extra);
    }
    if (tty) std::fprintf(stderr, "\r\033[K");
    char val_text[96] = "-";
    if (st.val_loss >= 0 && st.val_l1 >= 0)
      std::snprintf(val_text, sizeof val_text, "%.6f  val L1 %.4f  dominant %.3f", st.val_loss, st.val_l1,
                    st.val_dominant);
    else if (st.val_loss >= 0)
      std::snprintf(val_text, sizeof val_text, "%.6f", st.val_loss);
    if (root && !quiet)
      std::printf("epoch %d/%ld  train loss %.6f  val loss %s  lr %.3g  %.1f samples/s  (%.1f s)  -> %s%s%s\n", st.epoch,
                epochs, st.train_loss, val_text, st.lr, double(st.samples) / std::max(st.seconds, 1e-9), st.seconds,
                out.c_str(), improved ? ", best so far -> " : "", improved ? keep_best.c_str() : "");
    if (root && !quiet && comm.size() > 1)
      std::printf("  rank 0: %.0f steps, %.3f MB sent per step, %.2f s in collectives\n", double(st.batches),
                  st.comm_bytes / 1e6 / double(std::max<std::int64_t>(st.batches, 1)), st.comm_seconds);
    std::fflush(stdout);
    const double trained_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Stopping is rank 0's decision (clocks and Ctrl-C differ between ranks).
    int stop[2] = {minutes > 0 && trained_s >= minutes * 60.0 && trainer.epoch() < epochs, int(g_stop)};
    comm.broadcast(stop, sizeof stop, 0);
    if (root && !quiet && !keep_best.empty() && (stop[0] || stop[1] || trainer.epoch() >= epochs))
      std::printf("best %s %.6f at epoch %d, written to %s\n", figure_name, best_val, best_epoch, keep_best.c_str());
    if (stop[0]) {
      if (root) std::printf("time budget of %g minutes reached after epoch %d (%s); model written to %s\n", minutes, st.epoch,
                  gat::hms(trained_s).c_str(), out.c_str());
      return 0;
    }
    if (stop[1]) {
      std::signal(SIGINT, SIG_DFL);
      if (root) std::printf("interrupted: stopped after epoch %d; resume with --resume %s\n", st.epoch, out.c_str());
      return 130;
    }
  }
  if (root)
    std::printf("trained %ld epochs in %s; model written to %s, loss curve to %s (+ %s)\n", epochs - first,
              gat::hms(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str(), out.c_str(),
              curve.c_str(), gatcore::character::history_csv_path(curve).c_str());
  return 0;
}

}  // namespace
