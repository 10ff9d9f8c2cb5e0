// `gat demo`: the library's DenseGATs, in a small configuration, trained by
// the library's Trainer on the embedded tube arm (character/data/tube_data.hpp)
// to correct linear blend skinning, then held-out errors against LBS: the
// kernels' smoke test, on the same path as gat train / gat eval.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <omp.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/data/tube_data.hpp"
#include "gatcore/models/predict.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/vulkan.hpp"
#include "progress.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

constexpr int kTrainPoses = 64, kHeldOutPoses = 16;

// DenseGATs scaled down to the tube: one dense module of three GAT blocks
// (4 heads of 4 features, a self-reinforced stream of 2), a 32-wide input
// transform and a 64-wide head.
ModelConfig demo_config() {
  ModelConfig c = ModelConfig::defaults("densegats", character::kTubeFeatures);
  c.transform = {32, 32};
  c.modules = 1, c.blocks = 3, c.heads = 4, c.head_dim = 4;
  c.head = {64};
  return c;
}

struct DemoArgs {
  long epochs = 75, batch_size = 8, seed = 7;
  float lr = 3e-3f;
  gat::CommonOptions common;
};

int run_demo(const DemoArgs& a);

}  // namespace

gat::Runner gat::setup_demo(CLI::App& gat) {
  auto a = std::make_shared<DemoArgs>();
  CLI::App& c = add_command(gat, "demo", "kernel smoke test: a small DenseGATs on the embedded two-bone tube vs LBS");
  set_details(c, "Trains the library's DenseGATs (a small configuration) on 64 poses of the embedded two-bone tube to "
                "correct linear blend skinning, then reports vertex errors on 16 held-out poses; exits 1 unless the "
                "correction beats LBS. It shows the kernels work; scripts/demo.sh runs the real pipeline on "
                "procedural characters.");
  c.add_option("--epochs", a->epochs, "passes over the 64 training poses")->check(int_in(1, 1000000))->capture_default_str();
  c.add_option("--batch", a->batch_size, "poses per step")->check(int_in(2, 256))->capture_default_str();
  add_seed(c, a->seed, "initialisation and pose seed");
  c.add_option("--lr", a->lr, "learning rate")->check(positive_number())->capture_default_str();
  add_device(c, a->common);
  add_threads(c, a->common);
  add_quiet(c, a->common);
  return [a] {
    apply_threads(a->common);
    return run_demo(*a);
  };
}

namespace {

int run_demo(const DemoArgs& a) {
  const Device dev = gat::device_from_flag(a.common.device, "demo");
  const std::uint64_t seed = std::uint64_t(a.seed);
  const std::vector<Sample> train = character::tube_samples(Task::displacement, kTrainPoses, seed * 2 + 1);
  const std::vector<Sample> held_out = character::tube_samples(Task::displacement, kHeldOutPoses, seed * 2 + 2);
  const character::TubeMesh arm = character::tube_mesh(character::tube_arm_options());
  // Features to zero mean and unit variance, targets (offsets of ~1e-2) to
  // unit variance: the statistics a checkpoint would carry.
  const Normaliser norm = Normaliser::fit(train, true);
  const auto model = make_model(demo_config(), seed);
  std::int64_t params = 0;
  for (const Var& p : model->parameters()) params += p.value().rows() * p.value().cols();
  model->to(dev);
  TrainOptions opt = TrainOptions::defaults_for(model->config());
  opt.batch_size = int(a.batch_size);
  opt.lr = a.lr;
  opt.sampling = Sampling::full;
  opt.seed = seed;
  Trainer trainer(*model, opt, norm);

  std::printf("gat demo: two-bone tube, %lld vertices, %lld edges (with self-loops); DenseGATs, %lld parameters; "
              "%d OpenMP threads\n",
              static_cast<long long>(arm.num_vertices()), static_cast<long long>(train[0].graph->num_edges()),
              static_cast<long long>(params), omp_get_max_threads());
  if (dev == Device::vulkan) std::printf("device: vulkan (%s)\n", vulkan::current_device().name.c_str());

  const long epochs = a.epochs;
  const auto t0 = std::chrono::steady_clock::now();
  gat::Progress progress("training", epochs, "epochs", a.common.quiet);
  for (long epoch = 1; epoch <= epochs; ++epoch) {
    progress.update(epoch - 1);
    const bool report = epoch == 1 || epoch % 10 == 0 || epoch == epochs;
    const EpochStats st = trainer.run_epoch(train, report ? held_out : std::vector<Sample>{});
    if (!std::isfinite(st.train_loss)) {
      std::fprintf(stderr, "gat demo: training diverged at epoch %ld (loss %g); try a smaller --lr\n", epoch,
                   st.train_loss);
      return 1;
    }
    if (!a.common.quiet && report) {
      progress.finish();
      std::printf("epoch %5ld  train MSE %.6f  held-out MSE %.6f\n", epoch, st.train_loss, st.val_loss);
    }
  }
  progress.finish();
  const double train_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Held-out poses, full mesh, eval-mode BatchNorm: the LBS error is the
  // target's length (reference - LBS), the corrected one what the
  // prediction leaves of it.
  double lbs_sum = 0, net_sum = 0, lbs_max = 0, net_max = 0, lbs_joint = 0, net_joint = 0;
  std::int64_t count = 0, joint_count = 0;
  for (const Sample& s : held_out) {
    const Tensor pred = predict(*model, s, norm);
    for (std::int64_t i = 0; i < arm.num_vertices(); ++i) {
      double e_lbs = 0, e_net = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = s.target.at(i, k), r = d - pred.at(i, k);
        e_lbs += d * d;
        e_net += r * r;
      }
      lbs_sum += std::sqrt(e_lbs);
      net_sum += std::sqrt(e_net);
      const float w = arm.bone1_weight[std::size_t(i)];
      if (w > 0.f && w < 1.f) {  // the blended elbow region
        lbs_joint += std::sqrt(e_lbs);
        net_joint += std::sqrt(e_net);
        ++joint_count;
      }
      lbs_max = std::fmax(lbs_max, std::sqrt(e_lbs));
      net_max = std::fmax(net_max, std::sqrt(e_net));
      ++count;
    }
  }
  std::printf("\ntrained %ld epochs (%lld Adam steps) in %.1f s\n", epochs,
              static_cast<long long>(trainer.optimiser().steps()), train_s);
  std::printf("held-out vertex error vs reference (%d poses, tube length 2):\n", kHeldOutPoses);
  std::printf("  %-26s mean %.5f  elbow-region mean %.5f  max %.5f\n", "LBS", lbs_sum / count,
              lbs_joint / joint_count, lbs_max);
  std::printf("  %-26s mean %.5f  elbow-region mean %.5f  max %.5f\n", "LBS + DenseGAT correction",
              net_sum / count, net_joint / joint_count, net_max);
  if (!(net_sum < lbs_sum)) {
    std::printf("the correction did not beat LBS; train longer (--epochs)\n");
    return 1;
  }
  std::printf("correction reduces the mean error by %.1fx\n", lbs_sum / net_sum);
  return 0;
}

}  // namespace
