// Whole-model benchmarks (bench_models.hpp has the workloads):
//   model_train/<name>         one training step (forward, loss, backward,
//                              Adam) on a fixed batch; batch building is not
//                              timed (the trainer does it on the host, once
//                              per step, and it is the same for every model)
//   model_infer/densegats      one 10k-vertex character, BatchNorm folded, no tape
//                              (Model::forward: the tape-free generic path)
//   model_infer_deploy/densegats[_bf16]
//                              the same character and weights through the
//                              deploy path (models/deploy.hpp: weights packed
//                              once, buffers allocated once), which gat deform
//                              and the runtime run; fp32 gives predict's
//                              numbers bitwise, _bf16 bf16 products;
//                              counter scratch_MiB: the plan's activations
//   model_peak_rss/<name>      peak resident memory of a fresh gatbench process
//                              that only builds the workload and runs training
//                              steps (--gatbench_peak_rss, bench_main.cpp)
//   gat_layer_{fwd,fwdbwd}     one GAT layer 64 -> 8 heads x 8 (Linear +
//                              additive attention), the unit PyG's GATConv is
// FLOP counters count the model's dense products (2 per multiply-add), which
// dominate: compare `flops` with gemm's rate on the same machine.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <memory>
#include <string>

#include "bench/bench_models.hpp"
#include "gatcore/models/deploy.hpp"
#include "gatcore/precision.hpp"
#include "gatcore/ops.hpp"

namespace {

using gatbench::ModelCase;
using gatcore::Tensor;
using gatcore::Var;

// Multiply-adds x 2 of every parameter matrix [in, out] applied to every row
// (Linear layers, GAT projections): the model's GEMM work per forward pass.
double forward_gemm_flops(const gatcore::models::Model& m, std::int64_t rows) {
  double f = 0;
  for (const Var& p : m.parameters())
    if (p.rows() > 1 && p.name().find("att_") == std::string::npos && p.name().find("bn.") == std::string::npos)
      f += 2.0 * double(p.rows()) * double(p.cols()) * double(rows);
  return f;
}

void model_train(benchmark::State& state, const gatbench::ModelWorkload& w) {
  auto& c = gatbench::cached<ModelCase>(w.name + "_train" + w.suffix(),
                                        [&] { return ModelCase(w.name, w.batch, w.vertices, w.precision); });
  const std::int64_t rows = c.batch.x.rows();
  state.SetLabel(std::to_string(w.batch) + "x" + std::to_string(w.vertices) + " vertices");
  // forward + backward (input and weight gradients) = 3x the forward products
  gatbench::run(state, gatbench::Cost{0, 3 * forward_gemm_flops(*c.model, rows), rows}, [&] {
    benchmark::DoNotOptimize(c.step());
  });
}

void model_infer_densegats(benchmark::State& state) {
  const std::int64_t n = state.range(0);
  auto& c = gatbench::cached<ModelCase>("densegats_infer" + std::to_string(n), [&] {
    ModelCase m("densegats", 1, n);
    m.model->fold_batch_norm();
    return m;
  });
  state.SetLabel("1 character, BatchNorm folded, no tape");
  gatbench::run(state, gatbench::Cost{0, forward_gemm_flops(*c.model, n), n}, [&] { c.infer(); });
}
BENCHMARK(model_infer_densegats)->ArgName("nodes")->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);

struct DeployCase {
  std::unique_ptr<gatcore::models::DeployPlan> plan;
  double flops = 0;
};

void model_infer_deploy(benchmark::State& state, gatcore::Precision precision) {
  const std::int64_t n = state.range(0);
  if (precision == gatcore::Precision::bf16 && !gatcore::bf16_supported()) {
    state.SkipWithError("bf16: this CPU has no AVX512_BF16");
    return;
  }
  auto& c = gatbench::cached<DeployCase>(
      "densegats_deploy" + std::string(gatcore::precision_name(precision)) + std::to_string(n), [&] {
        ModelCase m("densegats", 1, n);  // the model_infer_densegats character and weights
        DeployCase d;
        d.flops = forward_gemm_flops(*m.model, n);
        gatcore::models::Normaliser norm;  // identity: the features are already on a unit scale
        norm.mean = Tensor::zeros(1, gatbench::kFeatures);
        norm.inv_std = Tensor::full(1, gatbench::kFeatures, 1.0f);
        auto dm = gatcore::models::make_deploy_model(*m.model, norm, gatcore::Device::cpu, precision);
        d.plan = std::make_unique<gatcore::models::DeployPlan>(dm, m.batch.graph);
        const Tensor& x = m.batch.x;
        for (std::int64_t r = 0; r < n; ++r) std::copy(x.row(r), x.row(r) + x.cols(), d.plan->input().row(r));
        return d;
      });
  state.SetLabel(std::string("1 character, deploy path, ") + gatcore::precision_name(precision));
  // run() normalises input() in place: with the identity normaliser the input stays the same.
  gatbench::run(state, gatbench::Cost{0, c.flops, n},
                [&] { benchmark::DoNotOptimize(c.plan->run().data()); });
  state.counters["scratch_MiB"] = double(c.plan->scratch_bytes()) / (1024.0 * 1024.0);  // activations, not weights
}
BENCHMARK_CAPTURE(model_infer_deploy, densegats, gatcore::Precision::fp32)
    ->ArgName("nodes")->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(model_infer_deploy, densegats_bf16, gatcore::Precision::bf16)
    ->ArgName("nodes")->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);

// Runs `gatbench --gatbench_peak_rss=<name>` and reads its "base peak" line (KiB).
void model_peak_rss(benchmark::State& state, const std::string& name) {
  std::array<char, 4096> self{};
  const ssize_t len = readlink("/proc/self/exe", self.data(), self.size() - 1);
  if (len <= 0) {
    state.SkipWithError("cannot find /proc/self/exe");
    return;
  }
  // (appended piecewise: GCC 12 warns falsely (-Wrestrict) on literal + string)
  std::string cmd(1, '\'');
  cmd.append(self.data(), std::size_t(len));
  cmd.append("' --gatbench_peak_rss=");
  cmd.append(name);
  double base = 0, peak = 0, step_ms = 0;
  for (auto _ : state) {
    std::unique_ptr<FILE, int (*)(FILE*)> p(popen(cmd.c_str(), "r"), pclose);
    if (!p || std::fscanf(p.get(), "%lf %lf %lf", &base, &peak, &step_ms) != 3) {
      state.SkipWithError(("no result from " + cmd).c_str());
      return;
    }
  }
  state.SetLabel("fresh process: setup, then training steps");
  state.counters["peak_MiB"] = peak / 1024;                 // whole process
  state.counters["setup_MiB"] = base / 1024;               // after building model, batch, Adam
  state.counters["step_MiB"] = (peak - base) / 1024;       // added by the training steps
  state.counters["step_ms"] = step_ms;
}

// One GAT layer as a user would write it: z = x W, additive attention over
// the mesh; `fwdbwd` adds an MSE loss and backward (weight and attention
// gradients; x is an input and needs none).
struct LayerCase {
  gatcore::GraphPtr g;
  Var x, W, a_l, a_r;
  Tensor target;
};

const LayerCase& layer_case(std::int64_t n) {
  return gatbench::cached<LayerCase>(n, [n] {
    LayerCase c;
    c.g = gatcore::share(gatbench::mesh_graph(n));
    c.x = Var(gatbench::random_tensor(n, 64, 31));
    c.W = Var::parameter(gatbench::random_tensor(64, 64, 32, -0.2f, 0.2f), "W");
    c.a_l = Var::parameter(gatbench::random_tensor(8, 8, 33), "att_dst");
    c.a_r = Var::parameter(gatbench::random_tensor(8, 8, 34), "att_src");
    c.target = gatbench::random_tensor(n, 64, 35);
    return c;
  });
}

void gat_layer_fwd(benchmark::State& state) {
  const LayerCase& c = layer_case(state.range(0));
  const double n = double(state.range(0));
  gatbench::run(state, gatbench::Cost{0, 2 * n * 64 * 64, state.range(0)}, [&] {
    gatcore::NoGradGuard ng;
    Var y = gatcore::gat_additive(c.g, gatcore::linear(c.x, c.W, Var{}), c.a_l, c.a_r, 0.2f);
    benchmark::DoNotOptimize(y.value().data());
  });
}
BENCHMARK(gat_layer_fwd)->ArgName("nodes")->Arg(1000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);

void gat_layer_fwdbwd(benchmark::State& state) {
  const LayerCase& c = layer_case(state.range(0));
  const double n = double(state.range(0));
  gatbench::run(state, gatbench::Cost{0, 4 * n * 64 * 64, state.range(0)}, [&] {
    for (const Var* p : {&c.W, &c.a_l, &c.a_r}) p->zero_grad();
    Var y = gatcore::gat_additive(c.g, gatcore::linear(c.x, c.W, Var{}), c.a_l, c.a_r, 0.2f);
    gatcore::backward(gatcore::mse_loss(y, c.target));
  });
}
BENCHMARK(gat_layer_fwdbwd)->ArgName("nodes")->Arg(1000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);

const bool registered = [] {
  for (const auto& [bench, w] : gatbench::train_workloads()) {
    // bf16 steps only where they run bf16 (compare_pyg skips the missing rows).
    if (w.precision == gatcore::Precision::bf16 && !gatcore::bf16_supported()) continue;
    benchmark::RegisterBenchmark(("model_train/" + w.name + w.suffix()).c_str(), model_train, w)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("model_peak_rss/" + w.name + w.suffix()).c_str(), model_peak_rss, bench)
        ->Iterations(1)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
  }
  return true;
}();

}  // namespace
