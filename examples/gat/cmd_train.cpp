// `gat train`: trains any model of issue 3 by name, with a progress line,
// validation every epoch, a resumable checkpoint every epoch and Ctrl-C
// handling. Until the character pipeline's datasets exist (--data), it
// trains on the embedded tube character (tube_data.hpp).
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <omp.h>

#include "commands.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/vulkan.hpp"
#include "tube_data.hpp"

using namespace gatcore;
using namespace gatcore::models;

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
               "                 [--device cpu|vulkan|auto]\n"
               "  Trains a model and writes a resumable checkpoint (safetensors + metadata) after\n"
               "  every epoch. Ctrl-C stops after the current epoch's checkpoint is written.\n"
               "  --model NAME   densegats (default), densegats-noself, densegats-nodense, origat,\n"
               "                 neuroskinning, neuroskinning-nopool, fc, pointnet; paper settings\n"
               "  --task T       weights or displacement (default: the model's paper task; e.g.\n"
               "                 --model neuroskinning --task displacement is DenseGATs' comparison)\n"
               "  --out FILE     checkpoint path (default model.gcm)\n"
               "  --epochs N     epochs to train, in total when resuming (default 10)\n"
               "  --resume FILE  continue from a checkpoint written by gat train (model, data, seed\n"
               "                 and batch size from the file)\n"
               "  --seed S       initialisation, sampling and data seed (default 0)\n"
               "  --threads T    OpenMP threads (default: all cores)\n"
               "  --batch B      characters per batch (default: paper, 8 or 12)\n"
               "  --lr LR        initial learning rate (default 1e-3)\n"
               "  --samples N    training samples of the embedded data (default 64; 8 more validate)\n"
               "  --data DATASET a dataset of the character pipeline (not available yet)\n"
               "  --device D     cpu (default), vulkan (the device GATCORE_VK_DEVICE selects, else the\n"
               "                 first GPU; lavapipe needs GATCORE_VK_ALLOW_CPU=1) or auto (Vulkan when a\n"
               "                 GPU is there, else the CPU); checkpoints are the same on every device\n"
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
  std::string model_name = "densegats", out = "model.gcm", resume, data, task, device = "cpu";
  long epochs = 10, seed = 0, threads = 0, batch = 0, samples = 64;
  float lr = 1e-3f;
  for (int i = 1; i < argc; ++i) {
    const bool v = i + 1 < argc;
    const char* a = argv[i];
    if (!std::strcmp(a, "-h") || !std::strcmp(a, "--help")) return usage(0);
    if (!std::strcmp(a, "--model") && v) model_name = argv[++i];
    else if (!std::strcmp(a, "--out") && v) out = argv[++i];
    else if (!std::strcmp(a, "--resume") && v) resume = argv[++i];
    else if (!std::strcmp(a, "--data") && v) data = argv[++i];
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
    else if (!std::strcmp(a, "--epochs") && v) { if (!parse_long(a, argv[++i], 1, 10000000, epochs)) return 2; }
    else if (!std::strcmp(a, "--seed") && v) { if (!parse_long(a, argv[++i], 0, 2147483647L, seed)) return 2; }
    else if (!std::strcmp(a, "--threads") && v) { if (!parse_long(a, argv[++i], 1, 1024, threads)) return 2; }
    else if (!std::strcmp(a, "--batch") && v) { if (!parse_long(a, argv[++i], 1, 4096, batch)) return 2; }
    else if (!std::strcmp(a, "--samples") && v) { if (!parse_long(a, argv[++i], 1, 1000000, samples)) return 2; }
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
  if (!data.empty()) {
    std::fprintf(stderr, "gat train: --data: datasets come with the character pipeline (gat dataset), which this "
                         "build does not have yet; omit --data to train on the embedded tube character\n");
    return 2;
  }
  if (threads > 0) omp_set_num_threads(int(threads));
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
    }
  } else {
    ModelConfig cfg = ModelConfig::defaults(model_name, demo::kTubeFeatures);
    if (!task.empty()) cfg.task = task == "weights" ? Task::weights : Task::displacement;
    cfg.out_dim = cfg.task == Task::weights ? demo::kTubeBones : 3;
    model = make_model(cfg, std::uint64_t(seed));
  }
  const ModelConfig& cfg = model->config();
  const auto train = demo::tube_samples(cfg.task, int(samples), std::uint64_t(seed) * 2 + 1);
  const auto val = demo::tube_samples(cfg.task, 8, std::uint64_t(seed) * 2 + 2);
  if (resume.empty()) norm = Normaliser::fit(train, cfg.task == Task::displacement);
  TrainOptions opt = TrainOptions::defaults_for(cfg);
  opt.seed = std::uint64_t(seed);
  opt.lr = lr;
  if (batch > 0) opt.batch_size = int(batch);
  // Parameters are drawn (or loaded) on the CPU and moved before the
  // optimiser allocates its moments next to them.
  model->to(dev);
  Trainer trainer(*model, opt, norm);
  if (!resume.empty()) restore_training_state(loaded.file, trainer, resume);

  std::printf("gat train: %s (%s), %lld parameters, embedded tube data: %zu training / %zu validation samples, "
              "batch %d, %d threads, device %s\n",
              cfg.name.c_str(), task_name(cfg.task), static_cast<long long>(model->registry().num_parameters()),
              train.size(), val.size(), opt.batch_size, omp_get_max_threads(),
              dev == Device::vulkan ? vulkan::current_device().name.c_str() : "cpu");
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
    const EpochStats st = trainer.run_epoch(train, val, progress);
    save_checkpoint(out, *model, norm, &trainer,
                    {{"data", "embedded tube character"}, {"skeleton", "upper_arm,forearm"}, {"seed", std::to_string(seed)},
                     {"samples", std::to_string(samples)}, {"batch", std::to_string(opt.batch_size)}});
    if (tty) std::fprintf(stderr, "\r\033[K");
    std::printf("epoch %d/%ld  train loss %.6f  val loss %.6f  lr %.3g  %.1f samples/s  (%.1f s)  -> %s\n", st.epoch,
                epochs, st.train_loss, st.val_loss, st.lr, double(st.samples) / std::max(st.seconds, 1e-9), st.seconds,
                out.c_str());
    std::fflush(stdout);
    if (g_stop) {
      std::signal(SIGINT, SIG_DFL);
      std::printf("interrupted: stopped after epoch %d; resume with --resume %s\n", st.epoch, out.c_str());
      return 130;
    }
  }
  std::printf("trained %ld epochs in %s; model written to %s\n", epochs - first,
              hms(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()).c_str(), out.c_str());
  return 0;
}
