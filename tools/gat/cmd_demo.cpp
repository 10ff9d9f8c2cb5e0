// `gat demo`: train a small DenseGATs-style network on the embedded two-bone
// tube to correct linear blend skinning, and report held-out errors against LBS.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <omp.h>

#include "gatcore/backend.hpp"
#include "gatcore/ops.hpp"
#include "gatcore/optim.hpp"
#include "gatcore/vulkan.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "tube_character.hpp"

using namespace gatcore;

namespace {

constexpr float kPi = 3.14159265358979f;

Tensor uniform(std::int64_t r, std::int64_t c, float bound, std::mt19937& rng) {
  std::uniform_real_distribution<float> U(-bound, bound);
  Tensor t = Tensor::empty(r, c);
  for (std::int64_t i = 0; i < r; ++i)
    for (std::int64_t j = 0; j < c; ++j) t.at(i, j) = U(rng);
  return t;
}

// A scaled-down DenseGATs: input transform, one dense module of GAT blocks
// (multi-head additive attention ++ self-reinforced linear stream,
// tanhshrink, BatchNorm) writing into one DenseNet buffer, and an MLP head.
struct MiniDenseGat {
  static constexpr int kIn = 9, kT = 32, kHeads = 4, kF = 4, kSelf = 2, kBlocks = 3, kHead = 64;
  static constexpr int kBlockOut = kHeads * kF + kSelf;
  std::vector<Var> params;
  Var t1_W, t1_b, t2_W, t2_b, h1_W, h1_b, h2_W, h2_b;
  struct Block {
    Var Wz, a_l, a_r, Ws, bs, gamma, beta;
    BatchNormState bn;
  };
  std::vector<Block> blocks;

  Device dev;

  // Parameters are drawn on the CPU (the same for every device) and moved to `dev`.
  MiniDenseGat(std::mt19937& rng, Device d) : dev(d) {
    auto P = [&](std::int64_t r, std::int64_t c, const std::string& name, float bound) {
      Var v = Var::parameter(to(uniform(r, c, bound, rng), dev), name);
      params.push_back(v);
      return v;
    };
    auto glorot = [](std::int64_t fan_in, std::int64_t fan_out) { return std::sqrt(6.f / float(fan_in + fan_out)); };
    t1_W = P(kIn, kT, "transform.0.W", glorot(kIn, kT));
    t1_b = P(1, kT, "transform.0.b", 0.f);
    t2_W = P(kT, kT, "transform.1.W", glorot(kT, kT));
    t2_b = P(1, kT, "transform.1.b", 0.f);
    int width = kT;
    for (int b = 0; b < kBlocks; ++b) {
      const std::string pre = "blocks." + std::to_string(b) + ".";
      Block bl;
      bl.Wz = P(width, kHeads * kF, pre + "W", glorot(width, kHeads * kF));
      bl.a_l = P(kHeads, kF, pre + "att_dst", glorot(kF, 1));
      bl.a_r = P(kHeads, kF, pre + "att_src", glorot(kF, 1));
      bl.Ws = P(width, kSelf, pre + "self.W", glorot(width, kSelf));
      bl.bs = P(1, kSelf, pre + "self.b", 0.f);
      bl.gamma = Var::parameter(to(Tensor::full(1, kBlockOut, 1.f), dev), pre + "bn.gamma");
      bl.beta = Var::parameter(to(Tensor::zeros(1, kBlockOut), dev), pre + "bn.beta");
      params.push_back(bl.gamma);
      params.push_back(bl.beta);
      blocks.push_back(std::move(bl));
      width += kBlockOut;
    }
    h1_W = P(width, kHead, "head.0.W", glorot(width, kHead));
    h1_b = P(1, kHead, "head.0.b", 0.f);
    h2_W = P(kHead, 3, "head.1.W", glorot(kHead, 3));
    h2_b = P(1, 3, "head.1.b", 0.f);
  }

  Var forward(const GraphPtr& g, const Tensor& x, bool training) {
    const std::int64_t n = g->num_nodes;
    // The dense buffer: [transform output | block 1 | block 2 | ...].
    Var buf(backend(dev).empty(n, kT + kBlocks * kBlockOut));
    Var t = tanh(linear(Var(to(x, dev)), t1_W, t1_b));
    tanh(linear(t, t2_W, t2_b), buf.cols_slice(0, kT));
    std::int64_t c0 = kT;
    for (Block& b : blocks) {
      Var in = buf.cols_slice(0, c0);
      Var agg = gat_additive(g, linear(in, b.Wz, Var{}), b.a_l, b.a_r, 0.2f);
      Var self = linear(in, b.Ws, b.bs);
      batch_norm(tanhshrink(concat({agg, self})), b.gamma, b.beta, b.bn, training,
                 buf.cols_slice(c0, c0 + kBlockOut));
      c0 += kBlockOut;
    }
    return linear(tanh(linear(buf, h1_W, h1_b)), h2_W, h2_b);
  }
};

struct Sample {
  Tensor features, target;  // target = displacement (reference − LBS), [n, 3]
  std::vector<demo::Vec3> lbs, reference;
};

Sample make_sample(const demo::TubeCharacter& c, const demo::Pose& p, float disp_scale) {
  Sample s;
  s.lbs = demo::skin_lbs(c, p);
  s.reference = demo::skin_target(c, p);
  s.features = demo::node_features(c, s.lbs, p);
  s.target = Tensor::empty(c.num_vertices(), 3);
  for (std::int64_t i = 0; i < c.num_vertices(); ++i)
    for (int k = 0; k < 3; ++k) s.target.at(i, k) = disp_scale * (s.reference[i][k] - s.lbs[i][k]);
  return s;
}

demo::Pose random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<float> bend(-110.f, 110.f), twist(-70.f, 70.f);
  return {bend(rng) * kPi / 180.f, twist(rng) * kPi / 180.f};
}

// Stacks samples into one block-diagonal batch.
std::pair<Tensor, Tensor> stack(const std::vector<Sample>& batch) {
  const std::int64_t n = batch[0].features.rows();
  Tensor x = Tensor::empty(n * std::int64_t(batch.size()), batch[0].features.cols());
  Tensor y = Tensor::empty(n * std::int64_t(batch.size()), 3);
  for (std::size_t b = 0; b < batch.size(); ++b) {
    x.rows_slice(b * n, (b + 1) * n).copy_from_(batch[b].features);
    y.rows_slice(b * n, (b + 1) * n).copy_from_(batch[b].target);
  }
  return {x, y};
}

struct DemoArgs {
  long epochs = 600, batch_size = 8, seed = 7;
  float lr = 3e-3f;
  gat::CommonOptions common;
};

int run_demo(const DemoArgs& a);

}  // namespace

gat::Runner gat::setup_demo(CLI::App& gat) {
  auto a = std::make_shared<DemoArgs>();
  CLI::App& c = add_command(gat, "demo", "kernel smoke test: a small DenseGATs on the embedded two-bone tube vs LBS");
  set_details(c, "Trains a small DenseGATs-style network on the embedded two-bone tube to correct linear blend "
                "skinning, then reports held-out vertex errors; exits 1 unless the correction beats LBS. It shows "
                "the kernels work; scripts/demo.sh runs the real pipeline on procedural characters.");
  c.add_option("--epochs", a->epochs, "training steps")->check(int_in(1, 1000000))->capture_default_str();
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
  const long epochs = a.epochs, batch_size = a.batch_size, seed = a.seed;
  const float lr = a.lr;
  const Device dev = gat::device_from_flag(a.common.device, "demo");
  std::mt19937 rng(static_cast<unsigned>(seed));
  const demo::TubeCharacter tube = demo::make_tube();
  const CsrGraph one = graph_from_triangles(tube.num_vertices(), tube.triangles);
  std::vector<const CsrGraph*> copies(static_cast<std::size_t>(batch_size), &one);
  const GraphPtr train_graph = share(batch_graphs(copies));
  const GraphPtr eval_graph = share(one);
  // Targets are scaled to unit variance (statistics of 64 random poses, as a
  // trainer would store them with the model): the raw offsets are ~1e-2.
  float disp_scale = 1.f;
  {
    double ss = 0;
    std::int64_t cnt = 0;
    std::mt19937 stats_rng(static_cast<unsigned>(seed) + 1u);
    for (int k = 0; k < 64; ++k) {
      Sample s = make_sample(tube, random_pose(stats_rng), 1.f);
      for (float v : s.target.to_vector()) ss += double(v) * v, ++cnt;
    }
    disp_scale = static_cast<float>(1.0 / std::sqrt(ss / double(cnt)));
  }

  std::printf("gat demo: two-bone tube, %lld vertices, %lld edges (with self-loops), %d OpenMP threads\n",
              static_cast<long long>(tube.num_vertices()), static_cast<long long>(one.num_edges()),
              omp_get_max_threads());
  if (dev == Device::vulkan) std::printf("device: vulkan (%s)\n", vulkan::current_device().name.c_str());

  MiniDenseGat net(rng, dev);
  Adam opt(net.params, AdamOptions{lr});
  std::vector<Sample> held_out;
  for (int k = 0; k < 16; ++k) held_out.push_back(make_sample(tube, random_pose(rng), disp_scale));

  const auto t0 = std::chrono::steady_clock::now();
  gat::Progress progress("training", epochs, "epochs", a.common.quiet);
  for (long epoch = 1; epoch <= epochs; ++epoch) {
    progress.update(epoch - 1);
    std::vector<Sample> batch;
    for (long b = 0; b < batch_size; ++b) batch.push_back(make_sample(tube, random_pose(rng), disp_scale));
    auto [x, y] = stack(batch);
    check_node_features(*train_graph, x, "demo features");
    Var loss = mse_loss(net.forward(train_graph, x, true), to(y, dev));
    opt.zero_grad();
    backward(loss);
    opt.step();
    const float l = to(loss.value(), Device::cpu).at(0, 0);  // on Vulkan: the step's one submission
    if (!std::isfinite(l)) {
      std::fprintf(stderr, "gat demo: training diverged at epoch %ld (loss %g); try a smaller --lr\n", epoch, l);
      return 1;
    }
    if (!a.common.quiet && (epoch == 1 || epoch % 50 == 0 || epoch == epochs)) {
      progress.finish();
      std::printf("epoch %5ld  train MSE %.6f\n", epoch, l);
    }
  }
  progress.finish();
  const double train_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Held-out poses, full mesh, eval-mode BatchNorm, no tape.
  NoGradGuard no_grad;
  double lbs_sum = 0, net_sum = 0, lbs_max = 0, net_max = 0, lbs_joint = 0, net_joint = 0;
  std::int64_t count = 0, joint_count = 0;
  for (const Sample& s : held_out) {
    const Tensor pred_value = to(net.forward(eval_graph, s.features, false).value(), Device::cpu);
    for (std::int64_t i = 0; i < tube.num_vertices(); ++i) {
      double e_lbs = 0, e_net = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = s.reference[i][k] - s.lbs[i][k];
        const double r = d - pred_value.at(i, k) / disp_scale;
        e_lbs += d * d;
        e_net += r * r;
      }
      lbs_sum += std::sqrt(e_lbs);
      net_sum += std::sqrt(e_net);
      if (tube.elbow_weight[i] > 0.f && tube.elbow_weight[i] < 1.f) {  // the blended elbow region
        lbs_joint += std::sqrt(e_lbs);
        net_joint += std::sqrt(e_net);
        ++joint_count;
      }
      lbs_max = std::fmax(lbs_max, std::sqrt(e_lbs));
      net_max = std::fmax(net_max, std::sqrt(e_net));
      ++count;
    }
  }
  std::printf("\ntrained %ld epochs in %.1f s\n", epochs, train_s);
  std::printf("held-out vertex error vs reference (16 poses, tube length 2):\n");
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
