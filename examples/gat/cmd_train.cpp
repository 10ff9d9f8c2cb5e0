// `gat train`: trains any model of issue 3 by name, with a progress line,
// validation every epoch, a resumable checkpoint every epoch and Ctrl-C
// handling. It trains on a dataset of the character pipeline (--data, see
// character/data/training_data.hpp) or on the embedded tube character
// (tube_data.hpp).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <omp.h>

#include "commands.hpp"
#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/viz/loss_curve.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/vulkan.hpp"
#include "tube_data.hpp"

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

int usage(int rc) {
  std::fprintf(rc ? stderr : stdout,
               "usage: gat train [--model NAME] [--task T] [--out FILE] [--epochs N] [--resume FILE] [--seed S]\n"
               "                 [--threads T] [--batch B] [--lr LR] [--samples N] [--data DATASET]\n"
               "                 [--device cpu|vulkan|auto] [--minutes M] [--loss-curve FILE.png]\n"
               "                 [--val-every K] [--sample-vertices V] [--loss mse|l1]\n"
               "  Trains a model and writes a resumable checkpoint (safetensors + metadata) after\n"
               "  every epoch. Ctrl-C stops after the current epoch's checkpoint is written.\n"
               "  --model NAME   densegats (default), densegats-noself, densegats-nodense, origat,\n"
               "                 neuroskinning, neuroskinning-nopool, fc, pointnet; paper settings\n"
               "  --task T       weights or displacement (default: the model's paper task; e.g.\n"
               "                 --model neuroskinning --task displacement is DenseGATs' comparison)\n"
               "  --loss L       displacement loss: mse (default, the paper) or l1 (mean absolute error:\n"
               "                 keeps LBS where unsure; closer to the mean vertex error gat eval reports)\n"
               "  --out FILE     checkpoint path (default model.gcm)\n"
               "  --epochs N     epochs to train, in total when resuming (default 10)\n"
               "  --resume FILE  continue from a checkpoint written by gat train (model, data, seed\n"
               "                 and batch size from the file)\n"
               "  --seed S       initialisation, sampling and data seed (default 0)\n"
               "  --threads T    OpenMP threads (default: all cores)\n"
               "  --batch B      characters per batch (default: paper, 8 or 12)\n"
               "  --lr LR        initial learning rate (default 1e-3)\n"
               "  --minutes M    time budget: no new epoch starts once M minutes of training have\n"
               "                 passed (the epoch running then finishes; --epochs still caps it)\n"
               "  --samples N    training samples of the embedded data (default 64; 8 more validate);\n"
               "                 with --data: poses per character and epoch (default: all of the dataset's)\n"
               "  --data DATASET a dataset written by gat dataset build: trains on its training characters,\n"
               "                 validates on its validation characters (bones: the dataset's super skeleton)\n"
               "  --device D     cpu (default), vulkan (the device GATCORE_VK_DEVICE selects, else the\n"
               "                 first GPU; lavapipe needs GATCORE_VK_ALLOW_CPU=1) or auto (Vulkan when a\n"
               "                 GPU is there, else the CPU); checkpoints are the same on every device\n"
               "  --loss-curve F the loss curve picture, rewritten after every epoch (default: the checkpoint's\n"
               "                 path with .loss.png for its extension); the losses also go to F's .csv\n"
               "  --val-every K  validate every K-th epoch and after the last one (default 1)\n"
               "  --sample-vertices V  vertices per training sample (default: paper, 1000 or 2048)\n"
               "  Without --data the embedded tube character is used: displacement models learn the\n"
               "  correction of LBS in random bend/twist poses; skin-weight models learn the\n"
               "  two-bone weights of tubes of varying resolution.\n");
  return rc;
}

bool parse_long(const char* flag, const char* v, long lo, long hi, long& out) {
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (!*v || *end || x < lo || x > hi) {
    std::fprintf(stderr, "gat train: %s expects an integer in [%ld, %ld], got '%s'\n", flag, lo, hi, v);
    return false;
  }
  out = x;
  return true;
}

std::string hms(double s) {
  const long t = long(s + 0.5);
  char b[32];
  std::snprintf(b, sizeof b, "%02ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  return b;
}

}  // namespace

int gat::cmd_train(int argc, char** argv) {
  std::string model_name = "densegats", out = "model.gcm", resume, data, task, device = "cpu", curve, loss;
  long epochs = 10, seed = 0, threads = 0, batch = 0, samples = 64;
  bool samples_set = false;
  float lr = 1e-3f;
  double minutes = 0;  // 0: no time budget
  long val_every = 1, sample_vertices = 0;
  for (int i = 1; i < argc; ++i) {
    const bool v = i + 1 < argc;
    const char* a = argv[i];
    if (!std::strcmp(a, "-h") || !std::strcmp(a, "--help")) return usage(0);
    if (!std::strcmp(a, "--model") && v) model_name = argv[++i];
    else if (!std::strcmp(a, "--out") && v) out = argv[++i];
    else if (!std::strcmp(a, "--resume") && v) resume = argv[++i];
    else if (!std::strcmp(a, "--data") && v) data = argv[++i];
    else if (!std::strcmp(a, "--loss-curve") && v) curve = argv[++i];
    else if (!std::strcmp(a, "--device") && v) {
      device = argv[++i];
      if (device != "cpu" && device != "vulkan" && device != "auto") {
        std::fprintf(stderr, "gat train: --device expects cpu, vulkan or auto, got '%s'\n", device.c_str());
        return 2;
      }
    }
    else if (!std::strcmp(a, "--task") && v) {
      task = argv[++i];
      if (task != "weights" && task != "displacement") {
        std::fprintf(stderr, "gat train: --task expects 'weights' or 'displacement', got '%s'\n", task.c_str());
        return 2;
      }
    }
    else if (!std::strcmp(a, "--loss") && v) {
      loss = argv[++i];
      if (loss != "mse" && loss != "l1") {
        std::fprintf(stderr, "gat train: --loss expects 'mse' or 'l1', got '%s'\n", loss.c_str());
        return 2;
      }
    }
    else if (!std::strcmp(a, "--epochs") && v) { if (!parse_long(a, argv[++i], 1, 10000000, epochs)) return 2; }
    else if (!std::strcmp(a, "--seed") && v) { if (!parse_long(a, argv[++i], 0, 2147483647L, seed)) return 2; }
    else if (!std::strcmp(a, "--threads") && v) { if (!parse_long(a, argv[++i], 1, 1024, threads)) return 2; }
    else if (!std::strcmp(a, "--batch") && v) { if (!parse_long(a, argv[++i], 1, 4096, batch)) return 2; }
    else if (!std::strcmp(a, "--samples") && v) { if (!parse_long(a, argv[++i], 1, 1000000, samples)) return 2; samples_set = true; }
    else if (!std::strcmp(a, "--sample-vertices") && v) { if (!parse_long(a, argv[++i], 1, 100000000, sample_vertices)) return 2; }
    else if (!std::strcmp(a, "--val-every") && v) { if (!parse_long(a, argv[++i], 1, 1000000, val_every)) return 2; }
    else if (!std::strcmp(a, "--minutes") && v) {
      char* end = nullptr;
      minutes = std::strtod(argv[++i], &end);
      if (*end || !(minutes > 0) || !std::isfinite(minutes)) {
        std::fprintf(stderr, "gat train: --minutes expects a positive number, got '%s'\n", argv[i]);
        return 2;
      }
    }
    else if (!std::strcmp(a, "--lr") && v) {
      char* end = nullptr;
      lr = std::strtof(argv[++i], &end);
      if (*end || !(lr > 0.f) || !std::isfinite(lr)) {
        std::fprintf(stderr, "gat train: --lr expects a positive number, got '%s'\n", argv[i]);
        return 2;
      }
    } else {
      std::fprintf(stderr, "gat train: unknown or incomplete option '%s'\n", a);
      return usage(2);
    }
  }
  if (threads > 0) omp_set_num_threads(int(threads));
  if (curve.empty()) curve = gatcore::character::default_curve_path(out);
  // Before any training: a curve that cannot be written would stop the run.
  if (const auto dir = std::filesystem::path(curve).parent_path(); !dir.empty() && !std::filesystem::is_directory(dir)) {
    std::fprintf(stderr, "gat train: --loss-curve %s: the directory %s does not exist\n", curve.c_str(),
                 dir.string().c_str());
    return 2;
  }
  const Device dev = device == "cpu" ? Device::cpu : vulkan::select(device == "auto" ? "auto" : "");

  std::unique_ptr<Model> model;
  Normaliser norm;
  LoadedModel loaded;
  if (!resume.empty()) {
    loaded = load_checkpoint(resume);
    model = std::move(loaded.model);
    norm = loaded.norm;
    // The run's data and batching come from the checkpoint, so the resumed
    // run continues exactly where the interrupted one stopped.
    const auto& md = loaded.file.metadata;
    if (md.count("seed") && md.count("samples") && md.count("batch")) {
      seed = std::stol(md.at("seed"));
      samples = std::stol(md.at("samples"));
      batch = std::stol(md.at("batch"));
      if (md.count("sample_vertices")) sample_vertices = std::stol(md.at("sample_vertices"));
    }
    if (md.count("data_path")) {
      if (data.empty()) data = md.at("data_path");
    } else if (!data.empty()) {
      std::fprintf(stderr, "gat train: %s was trained on the embedded tube data, not a dataset; drop --data\n",
                   resume.c_str());
      return 2;
    }
  }
  std::unique_ptr<character::TrainingData> td;
  if (!data.empty()) {
    td = std::make_unique<character::TrainingData>(character::load_training_data(data));
    if (resume.empty() && !samples_set) samples = 0;
    if (!resume.empty()) {
      const auto& md = loaded.file.metadata;
      if (md.count("data_hash") && md.at("data_hash") != td->hash) {
        std::fprintf(stderr, "gat train: %s has changed since %s was trained on it (hash %s, checkpoint %s)\n",
                     data.c_str(), resume.c_str(), td->hash.c_str(), md.at("data_hash").c_str());
        return 2;
      }
      if (md.count("skeleton") && md.at("skeleton") != character::joined_bone_names(td->super)) {
        std::fprintf(stderr, "gat train: %s's super skeleton differs from the one %s was trained on\n", data.c_str(),
                     resume.c_str());
        return 2;
      }
    }
  }
  if (resume.empty()) {
    ModelConfig cfg = ModelConfig::defaults(model_name, demo::kTubeFeatures);
    if (!task.empty()) cfg.task = task == "weights" ? Task::weights : Task::displacement;
    if (td) cfg.in_dim = td->feature_dim(cfg.task);
    cfg.out_dim = cfg.task == Task::weights ? (td ? td->super.num_bones() : demo::kTubeBones) : 3;
    if (cfg.name == "skinweights-any") {  // its columns are each vertex's own nearest bones, not the super skeleton
      if (!td) {
        std::fprintf(stderr, "gat train: skinweights-any learns from a dataset's characters (--data)\n");
        return 2;
      }
      cfg.in_dim = character::bone_candidate_feature_dim(character::kDefaultCandidates);
      cfg.out_dim = character::kDefaultCandidates;
    }
    if (!loss.empty()) {
      if (cfg.task == Task::weights) {
        std::fprintf(stderr, "gat train: --loss applies to displacement models; %s learns skin weights (KL)\n",
                     cfg.name.c_str());
        return 2;
      }
      cfg.loss = loss == "l1" ? DisplacementLoss::l1 : DisplacementLoss::mse;
    }
    model = make_model(cfg, std::uint64_t(seed));
  }
  const ModelConfig& cfg = model->config();
  if (!resume.empty() && !loss.empty() && loss != displacement_loss_name(cfg.loss)) {
    std::fprintf(stderr, "gat train: %s was trained with the %s loss; a resumed run keeps it (drop --loss %s)\n",
                 resume.c_str(), displacement_loss_name(cfg.loss), loss.c_str());
    return 2;
  }
  const bool any_skeleton = cfg.name == "skinweights-any";
  if (td && !any_skeleton) {
    GATCORE_CHECK(cfg.in_dim == td->feature_dim(cfg.task) &&
                      (cfg.task != Task::weights || cfg.out_dim == td->super.num_bones()),
                  "model '", resume, "' takes ", cfg.in_dim, " features / ", cfg.out_dim, " outputs; dataset ", data,
                  " has ", td->feature_dim(cfg.task), " features over ", td->super.num_bones(), " bones");
  }
  int geodesic_k = 1;
  for (int k : model->pool_sizes()) geodesic_k = std::max(geodesic_k, k);
  const auto data_samples = [&](character::DatasetPart part, int epoch) {
    if (any_skeleton) return character::bone_candidate_samples(*td, part, int(cfg.out_dim));
    return character::training_samples(*td, cfg.task, part, epoch, geodesic_k, int(samples));
  };
  std::vector<Sample> train = td ? data_samples(character::DatasetPart::train, 0)
                                 : demo::tube_samples(cfg.task, int(samples), std::uint64_t(seed) * 2 + 1);
  const std::vector<Sample> val = td ? data_samples(character::DatasetPart::validation, 0)
                                     : demo::tube_samples(cfg.task, 8, std::uint64_t(seed) * 2 + 2);
  if (train.empty()) {
    std::fprintf(stderr, "gat train: %s has no training samples\n", data.c_str());
    return 2;
  }
  if (resume.empty()) norm = Normaliser::fit(train, cfg.task == Task::displacement);
  TrainOptions opt = TrainOptions::defaults_for(cfg);
  opt.seed = std::uint64_t(seed);
  opt.lr = lr;
  if (batch > 0) opt.batch_size = int(batch);
  if (sample_vertices > 0) opt.sample_vertices = sample_vertices;
  // Parameters are drawn (or loaded) on the CPU and moved before the
  // optimiser allocates its moments next to them.
  model->to(dev);
  Trainer trainer(*model, opt, norm);
  if (!resume.empty()) restore_training_state(loaded.file, trainer, resume);

  const std::string source = td ? "dataset " + data + " (" + std::to_string(td->super.num_bones()) + " bones)"
                                : std::string("embedded tube data");
  const std::string task_text = cfg.task == Task::weights
                                    ? std::string("weights, KL loss")
                                    : std::string("displacement, ") + displacement_loss_name(cfg.loss) + " loss";
  std::printf("gat train: %s (%s), %lld parameters, %s: %zu training / %zu validation samples, "
              "batch %d, %d threads, device %s\n",
              cfg.name.c_str(), task_text.c_str(), static_cast<long long>(model->registry().num_parameters()),
              source.c_str(), train.size(), val.size(), opt.batch_size, omp_get_max_threads(),
              dev == Device::vulkan ? vulkan::current_device().name.c_str() : "cpu");
  std::map<std::string, std::string> extra{{"seed", std::to_string(seed)},
                                           {"samples", std::to_string(samples)},
                                           {"batch", std::to_string(opt.batch_size)},
                                           {"sample_vertices", std::to_string(opt.sample_vertices)}};
  // The node features a character command (predict-weights, deform) must
  // compute for this model (character_model.hpp).
  extra["features"] = td ? (any_skeleton ? "bone-candidates" : cfg.task == Task::weights ? "neuroskinning" : "densegats")
                        : "tube";
  if (td) {
    extra["data"] = "dataset";
    extra["data_path"] = std::filesystem::absolute(data).string();
    extra["data_hash"] = td->hash;
    extra["skeleton"] = character::joined_bone_names(td->super);
    if (cfg.task == Task::displacement)
      extra["distortion_scales"] = character::format_distortion_scales(td->description.distortion_scales);
    // For people reading the checkpoint: the feature layout ("features" above
    // is the key predict-weights / deform dispatch on); the columns follow "skeleton" (bone names normalised by
    // character::normalise_bone_name), the statistics are norm.mean / norm.inv_std.
    extra["feature_layout"] = any_skeleton
                            ? "bone-candidates: rest position (3), rest normal (3), then per each vertex's nearest "
                              "bones (out_dim of them, nearest first) 10 bone-relative columns "
                              "(character/features/bone_candidates.hpp); outputs: those bones"
                            : cfg.task == Task::weights
                            ? "neuroskinning: rest position (3), rest normal (3), distance to each skeleton bone "
                              "segment; world frame, hips at the origin, height 1 (character::compute_normalisation)"
                            : "densegats: posed position (3), posed normal (3), distance to each skeleton joint, "
                              "then 3 per distortion scale (character/deform/detail_distortion.hpp); root frame, "
                              "normalised like neuroskinning";
  } else {
    extra["data"] = "embedded tube character";
    extra["skeleton"] = "upper_arm,forearm";
  }
  std::vector<LossRecord> history;
  if (!resume.empty() && loaded.file.metadata.count("loss_history")) {
    history = gatcore::character::parse_history(loaded.file.metadata.at("loss_history"), resume);
    std::erase_if(history, [&](const LossRecord& r) { return r.epoch > trainer.epoch(); });
  }
  if (trainer.epoch() >= epochs) {
    std::printf("the checkpoint has already trained %d of %ld epochs; nothing to do\n", trainer.epoch(), epochs);
    return 0;
  }
  const bool tty = isatty(fileno(stderr));
  std::signal(SIGINT, on_sigint);
  if (tty) std::fprintf(stderr, "(Ctrl-C stops after the current epoch's checkpoint; twice quits at once)\n");
  const auto t0 = std::chrono::steady_clock::now();
  const int first = trainer.epoch();
  while (trainer.epoch() < epochs) {
    // Displacement datasets: the random poses and windows of this epoch
    // (deterministic per seed and epoch, so a resumed run sees the same).
    if (td && cfg.task == Task::displacement && trainer.epoch() > 0)
      train = data_samples(character::DatasetPart::train, trainer.epoch());
    const auto te = std::chrono::steady_clock::now();
    const auto progress = [&](int e, std::int64_t b, std::int64_t nb, double loss) {
      if (!tty) return;
      const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - te).count();
      const double sps = double(std::min<std::int64_t>(b * opt.batch_size, std::int64_t(train.size()))) / std::max(el, 1e-9);
      const double done = double(e - 1 - first) + double(b) / double(nb);
      const double tot = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double eta = done > 0 ? tot / done * (double(epochs - first) - done) : 0;
      std::fprintf(stderr, "\repoch %d/%ld  batch %lld/%lld  loss %.5f  lr %.3g  %.1f samples/s  ETA %s ", e, epochs,
                   static_cast<long long>(b), static_cast<long long>(nb), loss, trainer.optimiser().lr(), sps,
                   hms(eta).c_str());
      std::fflush(stderr);
    };
    const bool last = trainer.epoch() + 1 >= epochs;
    const bool validate = last || (trainer.epoch() + 1) % val_every == 0;
    const EpochStats st = trainer.run_epoch(train, validate ? val : std::vector<Sample>{}, progress);
    history.push_back({st.epoch, st.train_loss, st.val_loss, double(st.lr), st.seconds});
    extra["loss_history"] = gatcore::character::format_history(history);
    save_checkpoint(out, *model, norm, &trainer, extra);
    gatcore::character::write_loss_outputs(history, curve);
    if (tty) std::fprintf(stderr, "\r\033[K");
    char val_text[32] = "-";
    if (st.val_loss >= 0) std::snprintf(val_text, sizeof val_text, "%.6f", st.val_loss);
    std::printf("epoch %d/%ld  train loss %.6f  val loss %s  lr %.3g  %.1f samples/s  (%.1f s)  -> %s\n", st.epoch,
                epochs, st.train_loss, val_text, st.lr, double(st.samples) / std::max(st.seconds, 1e-9), st.seconds,
                out.c_str());
    std::fflush(stdout);
    const double trained_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (minutes > 0 && trained_s >= minutes * 60.0 && trainer.epoch() < epochs) {
      std::printf("time budget of %g minutes reached after epoch %d (%s); model written to %s\n", minutes, st.epoch,
                  hms(trained_s).c_str(), out.c_str());
      return 0;
    }
    if (g_stop) {
      std::signal(SIGINT, SIG_DFL);
      std::printf("interrupted: stopped after epoch %d; resume with --resume %s\n", st.epoch, out.c_str());
      return 130;
    }
  }
  std::printf("trained %ld epochs in %s; model written to %s, loss curve to %s (+ %s)\n", epochs - first,
              hms(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str(), out.c_str(),
              curve.c_str(), gatcore::character::history_csv_path(curve).c_str());
  return 0;
}
