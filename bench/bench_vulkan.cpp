// Vulkan variants of the graph-attention kernel benchmarks and the model's
// forward GEMM: the same inputs as bench_kernels.cpp, run through
// backend(Device::vulkan); every iteration records the op and waits for it
// (vulkan::sync), so times include one submission. Device: GATCORE_VK_DEVICE,
// else the first GPU (lavapipe with GATCORE_VK_ALLOW_CPU=1: correctness-grade
// numbers only). Without a device every Vulkan benchmark reports the label
// "no Vulkan device" and times an empty loop.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "bench/bench_util.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/vulkan.hpp"

namespace {

using gatbench::Cost;
using gatbench::kF32;
using gatcore::Backend;
using gatcore::CsrGraph;
using gatcore::Device;
using gatcore::DType;
using gatcore::Tensor;

constexpr int H = 8, F = 8, HF = H * F;
constexpr float kSlope = 0.2f;

bool vulkan_ready(benchmark::State& state) {
  static int ok = -1;
  static std::string why;
  if (ok < 0) {
    try {
      gatcore::vulkan::init();
      ok = 1;
      benchmark::AddCustomContext("vulkan_device", gatcore::vulkan::current_device().name);
    } catch (const std::exception& e) {
      ok = 0;
      why = e.what();
    }
  }
  if (!ok) {
    state.SetLabel("no Vulkan device");
    for (auto _ : state) {
    }
  }
  return ok == 1;
}

struct VkCase {
  CsrGraph g;
  Tensor z, a_l, a_r, el, er, alpha, d_alpha, d_out, d_el, d_er;  // device tensors
  double N() const { return static_cast<double>(g.num_nodes); }
  double E() const { return static_cast<double>(g.num_edges()); }
};

const VkCase& vk_case(std::int64_t nodes) {
  return gatbench::cached<VkCase>(nodes + 1'000'000'000, [nodes] {
    auto V = [](const Tensor& t) { return gatcore::to(t, Device::vulkan); };
    VkCase m;
    m.g = gatbench::mesh_graph(nodes);
    const std::int64_t n = m.g.num_nodes, E = m.g.num_edges();
    m.z = V(gatbench::random_tensor(n, HF, 1));
    m.a_l = V(gatbench::random_tensor(H, F, 2));
    m.a_r = V(gatbench::random_tensor(H, F, 3));
    m.el = V(gatbench::random_tensor(n, H, 4));
    m.er = V(gatbench::random_tensor(n, H, 5));
    m.alpha = V(gatbench::uniform_attention(m.g, H));
    m.d_alpha = V(gatbench::random_tensor(E, H, 6));
    m.d_out = V(gatbench::random_tensor(n, HF, 7));
    m.d_el = V(gatbench::random_tensor(n, H, 8));
    m.d_er = V(gatbench::random_tensor(n, H, 9));
    return m;
  });
}

void sizes(benchmark::internal::Benchmark* b) {
  b->ArgName("nodes")->Arg(1000)->Arg(10000)->Arg(100000);
  b->UseRealTime()->Unit(benchmark::kMicrosecond);
}

// Runs `op` once (uploading the graph, creating pipelines), then times op + sync.
template <class Op>
void run(benchmark::State& state, const Cost& c, Op&& op) {
  gatbench::run(state, c, [&] {
    op();
    gatcore::vulkan::sync();
  });
}

Backend& gpu() { return gatcore::backend(Device::vulkan); }

void vk_attention_projection_fwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor el = gpu().empty(m.g.num_nodes, H, DType::f32), er = gpu().empty(m.g.num_nodes, H, DType::f32);
  run(state, {kF32 * (m.N() * HF + 2 * m.N() * H), 4 * m.N() * HF, m.g.num_nodes},
      [&] { gpu().attention_projection_forward(m.z, m.a_l, m.a_r, el, er); });
}
BENCHMARK(vk_attention_projection_fwd)->Apply(sizes);

void vk_attention_projection_bwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor d_z = gpu().zeros(m.g.num_nodes, HF, DType::f32), d_al = gpu().zeros(H, F, DType::f32),
         d_ar = gpu().zeros(H, F, DType::f32);
  run(state, {kF32 * (3 * m.N() * HF + 2 * m.N() * H), 8 * m.N() * HF, m.g.num_nodes},
      [&] { gpu().attention_projection_backward(m.z, m.a_l, m.a_r, m.d_el, m.d_er, d_z, d_al, d_ar); });
}
BENCHMARK(vk_attention_projection_bwd)->Apply(sizes);

void vk_gat_fused_additive_fwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor out = gpu().empty(m.g.num_nodes, HF, DType::f32), alpha = gpu().empty(m.g.num_edges(), H, DType::f32);
  run(state, {gatbench::csr_bytes(m.g) + kF32 * (m.E() * HF + m.N() * HF + m.E() * H), 2 * m.E() * HF,
              m.g.num_nodes},
      [&] { gpu().gat_fused_additive_forward(m.g, m.z, m.el, m.er, kSlope, out, alpha); });
}
BENCHMARK(vk_gat_fused_additive_fwd)->Apply(sizes);

void vk_gat_fused_additive_bwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor d_z = gpu().zeros(m.g.num_nodes, HF, DType::f32), d_el = gpu().zeros(m.g.num_nodes, H, DType::f32),
         d_er = gpu().zeros(m.g.num_nodes, H, DType::f32);
  run(state, {gatbench::csr_bytes(m.g) + kF32 * (2 * m.E() * HF + 3 * m.N() * HF), 4 * m.E() * HF,
              m.g.num_nodes},
      [&] {
        gpu().gat_fused_additive_backward(m.g, m.z, m.el, m.er, kSlope, m.alpha, m.d_out, d_z, d_el, d_er);
      });
}
BENCHMARK(vk_gat_fused_additive_bwd)->Apply(sizes);

void vk_gat_fused_dot_fwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor out = gpu().empty(m.g.num_nodes, HF, DType::f32), alpha = gpu().empty(m.g.num_edges(), H, DType::f32);
  const float scale = 1.0f / std::sqrt(static_cast<float>(F));
  run(state, {gatbench::csr_bytes(m.g) + kF32 * (2 * m.E() * HF + m.N() * HF), 4 * m.E() * HF, m.g.num_nodes},
      [&] { gpu().gat_fused_dot_forward(m.g, m.z, H, scale, out, alpha); });
}
BENCHMARK(vk_gat_fused_dot_fwd)->Apply(sizes);

void vk_gat_fused_dot_bwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const VkCase& m = vk_case(state.range(0));
  Tensor d_z = gpu().zeros(m.g.num_nodes, HF, DType::f32);
  const float scale = 1.0f / std::sqrt(static_cast<float>(F));
  run(state, {gatbench::csr_bytes(m.g) + kF32 * (3 * m.E() * HF + 3 * m.N() * HF), 6 * m.E() * HF,
              m.g.num_nodes},
      [&] { gpu().gat_fused_dot_backward(m.g, m.z, H, scale, m.alpha, m.d_out, d_z); });
}
BENCHMARK(vk_gat_fused_dot_bwd)->Apply(sizes);

void vk_gemm_fwd(benchmark::State& state) {
  if (!vulkan_ready(state)) return;
  const std::int64_t M = state.range(0), K = state.range(1), N = state.range(2);
  Tensor A = gatcore::to(gatbench::random_tensor(M, K, 21), Device::vulkan);
  Tensor B = gatcore::to(gatbench::random_tensor(K, N, 22), Device::vulkan);
  Tensor C = gpu().empty(M, N, DType::f32);
  const double m = static_cast<double>(M), k = static_cast<double>(K), n = static_cast<double>(N);
  run(state, {kF32 * (m * k + k * n + m * n), 2 * m * k * n, M},
      [&] { gpu().gemm(A, false, B, false, C, 1.0f, 0.0f); });
}
BENCHMARK(vk_gemm_fwd)
    ->ArgNames({"M", "K", "N"})
    ->Args({8000, 504, 512})
    ->Args({8000, 392, 64})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
