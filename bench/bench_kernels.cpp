// Every CPU kernel of kernels/*.hpp that the GAT models spend their time in,
// forward and backward, on synthetic character meshes of 1k, 10k and 100k
// vertices with H = 8 heads of F = 8 features, plus the dense GEMMs of the
// model's layer shapes. See bench/README.md for the cost models.
#include <benchmark/benchmark.h>

#include <cmath>
#include <exception>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "bench/bench_util.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/aggregation.hpp"
#include "src/backends/cpu/attention_projection.hpp"
#include "src/backends/cpu/dense_concat.hpp"
#include "src/backends/cpu/edge_softmax.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/inference.hpp"
#include "src/backends/cpu/pooling.hpp"

namespace {

using gatbench::Cost;
using gatbench::kF32;
using gatcore::CsrGraph;
using gatcore::Tensor;
using gatcore::Precision;
namespace cpu = gatcore::cpu;

constexpr int H = 8;                 // heads
constexpr int F = 8;                 // features per head
constexpr int HF = H * F;            // width of z
constexpr int kNeighbourhood = 16;   // neighbour_mean: k nearest vertices
constexpr int kSegments = 4;         // pooling: a batch of 4 meshes
constexpr int kDenseWidth = 512;     // DenseNet buffer width for concat copies
constexpr float kSlope = 0.2f;       // LeakyReLU slope of additive attention
const float kDotScale = 1.0f / std::sqrt(static_cast<float>(F));

// Inputs shared by every benchmark of one mesh size (built once per size).
struct MeshCase {
  CsrGraph g;
  CsrGraph nbr;  // k nearest by hops, for neighbour_mean
  std::vector<std::int64_t> seg_ptr;
  Tensor z;          // [n, HF] node features (also h of dot attention)
  Tensor a_l, a_r;   // [H, F]
  Tensor el, er;     // [n, H]
  Tensor alpha;      // [E, H] a valid attention (rows sum to 1)
  Tensor d_alpha;    // [E, H]
  Tensor d_out;      // [n, HF]
  Tensor d_el, d_er; // [n, H]
  Tensor d_seg;      // [S, HF]

  std::int64_t n() const { return g.num_nodes; }
  double E() const { return static_cast<double>(g.num_edges()); }
  double N() const { return static_cast<double>(g.num_nodes); }
};

const MeshCase& mesh_case(std::int64_t nodes) {
  return gatbench::cached<MeshCase>(nodes, [nodes] {
    MeshCase m;
    m.g = gatbench::mesh_graph(nodes);
    m.nbr = gatbench::hop_neighbourhoods(m.g, kNeighbourhood);
    for (int s = 0; s <= kSegments; ++s) m.seg_ptr.push_back(nodes * s / kSegments);
    const std::int64_t n = m.g.num_nodes, E = m.g.num_edges();
    m.z = gatbench::random_tensor(n, HF, 1);
    m.a_l = gatbench::random_tensor(H, F, 2);
    m.a_r = gatbench::random_tensor(H, F, 3);
    m.el = gatbench::random_tensor(n, H, 4);
    m.er = gatbench::random_tensor(n, H, 5);
    m.alpha = gatbench::uniform_attention(m.g, H);
    m.d_alpha = gatbench::random_tensor(E, H, 6);
    m.d_out = gatbench::random_tensor(n, HF, 7);
    m.d_el = gatbench::random_tensor(n, H, 8);
    m.d_er = gatbench::random_tensor(n, H, 9);
    m.d_seg = gatbench::random_tensor(kSegments, HF, 10);
    return m;
  });
}

// Sizes, names and timing shared by the graph benchmarks.
void mesh_sizes(benchmark::internal::Benchmark* b) {
  b->ArgName("nodes")->Arg(1000)->Arg(10000)->Arg(100000);
  b->UseRealTime()->Unit(benchmark::kMicrosecond);
}

const MeshCase& setup(benchmark::State& state) {
  const MeshCase& m = mesh_case(state.range(0));
  state.SetLabel("E=" + std::to_string(m.g.num_edges()) + " deg=" +
                 std::to_string(m.E() / m.N()).substr(0, 4));
  return m;
}

// ---- attention projection ------------------------------------------------------------
void attention_projection_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor el = Tensor::empty(m.n(), H), er = Tensor::empty(m.n(), H);
  const Cost c{kF32 * (m.N() * HF + 2 * m.N() * H), 4 * m.N() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::attention_projection_forward(m.z, m.a_l, m.a_r, el, er); });
}
BENCHMARK(attention_projection_fwd)->Apply(mesh_sizes);

void attention_projection_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_z = Tensor::zeros(m.n(), HF), d_al = Tensor::zeros(H, F), d_ar = Tensor::zeros(H, F);
  // reads z, d_el, d_er; d_z read + written
  const Cost c{kF32 * (3 * m.N() * HF + 2 * m.N() * H), 8 * m.N() * HF, m.n()};
  gatbench::run(state, c, [&] {
    cpu::attention_projection_backward(m.z, m.a_l, m.a_r, m.d_el, m.d_er, d_z, d_al, d_ar);
  });
}
BENCHMARK(attention_projection_bwd)->Apply(mesh_sizes);

// ---- edge softmax ----------------------------------------------------------------------
void edge_softmax_additive_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor alpha = Tensor::empty(m.g.num_edges(), H);
  // logit, LeakyReLU, max, subtract, exp, sum, scale per edge and head
  const Cost c{gatbench::csr_bytes(m.g) + kF32 * (2 * m.N() * H + m.E() * H), 8 * m.E() * H, m.n()};
  gatbench::run(state, c, [&] { cpu::edge_softmax_additive_forward(m.g, m.el, m.er, kSlope, alpha); });
}
BENCHMARK(edge_softmax_additive_fwd)->Apply(mesh_sizes);

void edge_softmax_additive_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_el = Tensor::zeros(m.n(), H), d_er = Tensor::zeros(m.n(), H);
  // reads el, er, alpha, d_alpha; d_el and d_er read + written; CSR and transpose
  const Cost c{gatbench::csr_bytes(m.g) + gatbench::transpose_bytes(m.g) +
                   kF32 * (2 * m.N() * H + 2 * m.E() * H + 4 * m.N() * H),
               8 * m.E() * H, m.n()};
  gatbench::run(state, c, [&] {
    cpu::edge_softmax_additive_backward(m.g, m.el, m.er, kSlope, m.alpha, m.d_alpha, d_el, d_er);
  });
}
BENCHMARK(edge_softmax_additive_bwd)->Apply(mesh_sizes);

void edge_softmax_dot_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor alpha = Tensor::empty(m.g.num_edges(), H);
  const Cost c{gatbench::csr_bytes(m.g) + kF32 * (m.N() * HF + m.E() * H), 2 * m.E() * HF + 6 * m.E() * H,
               m.n()};
  gatbench::run(state, c, [&] { cpu::edge_softmax_dot_forward(m.g, m.z, H, kDotScale, alpha); });
}
BENCHMARK(edge_softmax_dot_fwd)->Apply(mesh_sizes);

void edge_softmax_dot_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_h = Tensor::zeros(m.n(), HF);
  // reads h, alpha, d_alpha; d_h read + written; both ends of each logit
  const Cost c{gatbench::csr_bytes(m.g) + gatbench::transpose_bytes(m.g) +
                   kF32 * (3 * m.N() * HF + 2 * m.E() * H),
               4 * m.E() * HF + 6 * m.E() * H, m.n()};
  gatbench::run(state, c, [&] {
    cpu::edge_softmax_dot_backward(m.g, m.z, H, kDotScale, m.alpha, m.d_alpha, d_h);
  });
}
BENCHMARK(edge_softmax_dot_bwd)->Apply(mesh_sizes);

// ---- aggregation -------------------------------------------------------------------------
void aggregate_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(m.n(), HF);
  const Cost c{gatbench::csr_bytes(m.g) + kF32 * (m.E() * H + 2 * m.N() * HF), 2 * m.E() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::aggregate_forward(m.g, m.alpha, m.z, out); });
}
BENCHMARK(aggregate_fwd)->Apply(mesh_sizes);

void aggregate_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_alpha = Tensor::empty(m.g.num_edges(), H), d_z = Tensor::zeros(m.n(), HF);
  // reads alpha, z, d_out; writes d_alpha; d_z read + written
  const Cost c{gatbench::csr_bytes(m.g) + gatbench::transpose_bytes(m.g) +
                   kF32 * (2 * m.E() * H + 4 * m.N() * HF),
               4 * m.E() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::aggregate_backward(m.g, m.alpha, m.z, m.d_out, d_alpha, d_z); });
}
BENCHMARK(aggregate_bwd)->Apply(mesh_sizes);

// ---- fused attention ------------------------------------------------------------------------
void gat_fused_additive_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(m.n(), HF), alpha = Tensor::empty(m.g.num_edges(), H);
  const Cost c{gatbench::csr_bytes(m.g) + kF32 * (2 * m.N() * HF + 2 * m.N() * H + m.E() * H),
               2 * m.E() * HF + 8 * m.E() * H, m.n()};
  gatbench::run(state, c,
                [&] { cpu::gat_fused_additive_forward(m.g, m.z, m.el, m.er, kSlope, out, alpha); });
}
BENCHMARK(gat_fused_additive_fwd)->Apply(mesh_sizes);

void gat_fused_additive_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_z = Tensor::zeros(m.n(), HF), d_el = Tensor::zeros(m.n(), H), d_er = Tensor::zeros(m.n(), H);
  // reads z, el, er, alpha, d_out; d_z, d_el, d_er read + written
  const Cost c{gatbench::csr_bytes(m.g) + gatbench::transpose_bytes(m.g) +
                   kF32 * (4 * m.N() * HF + 6 * m.N() * H + m.E() * H),
               4 * m.E() * HF + 8 * m.E() * H, m.n()};
  gatbench::run(state, c, [&] {
    cpu::gat_fused_additive_backward(m.g, m.z, m.el, m.er, kSlope, m.alpha, m.d_out, d_z, d_el, d_er);
  });
}
BENCHMARK(gat_fused_additive_bwd)->Apply(mesh_sizes);

void gat_fused_dot_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(m.n(), HF), alpha = Tensor::empty(m.g.num_edges(), H);
  const Cost c{gatbench::csr_bytes(m.g) + kF32 * (2 * m.N() * HF + m.E() * H), 4 * m.E() * HF + 6 * m.E() * H,
               m.n()};
  gatbench::run(state, c, [&] { cpu::gat_fused_dot_forward(m.g, m.z, H, kDotScale, out, alpha); });
}
BENCHMARK(gat_fused_dot_fwd)->Apply(mesh_sizes);

void gat_fused_dot_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_z = Tensor::zeros(m.n(), HF);
  // reads z, alpha, d_out; d_z read + written. d_alpha, aggregation d_z and
  // both ends of the logit gradient: 8 E HF.
  const Cost c{gatbench::csr_bytes(m.g) + gatbench::transpose_bytes(m.g) +
                   kF32 * (4 * m.N() * HF + m.E() * H),
               8 * m.E() * HF + 6 * m.E() * H, m.n()};
  gatbench::run(state, c,
                [&] { cpu::gat_fused_dot_backward(m.g, m.z, H, kDotScale, m.alpha, m.d_out, d_z); });
}
BENCHMARK(gat_fused_dot_bwd)->Apply(mesh_sizes);

// ---- DenseNet concatenation copies ----------------------------------------------------------------
void dense_concat_copy_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor buffer = Tensor::zeros(m.n(), kDenseWidth);
  const Cost c{kF32 * 2 * m.N() * HF, 0, m.n()};
  gatbench::run(state, c, [&] { cpu::concat_copy_forward(m.z, buffer, 2 * HF); });
}
BENCHMARK(dense_concat_copy_fwd)->Apply(mesh_sizes);

void dense_concat_copy_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_buffer = gatbench::random_tensor(m.n(), kDenseWidth, 11);
  Tensor d_src = Tensor::zeros(m.n(), HF);
  const Cost c{kF32 * 3 * m.N() * HF, m.N() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::concat_copy_backward(d_buffer, 2 * HF, d_src); });
}
BENCHMARK(dense_concat_copy_bwd)->Apply(mesh_sizes);

// ---- pooling ------------------------------------------------------------------------------------
void segment_max_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(kSegments, HF), argmax = Tensor::empty(kSegments, HF, gatcore::DType::i32);
  const Cost c{kF32 * (m.N() * HF + 2.0 * kSegments * HF), m.N() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::segment_max_forward(m.z, m.seg_ptr, out, argmax); });
}
BENCHMARK(segment_max_fwd)->Apply(mesh_sizes);

void segment_max_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(kSegments, HF), argmax = Tensor::empty(kSegments, HF, gatcore::DType::i32);
  Tensor d_x = Tensor::zeros(m.n(), HF);
  try {
    cpu::segment_max_forward(m.z, m.seg_ptr, out, argmax);
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  // reads d_out and argmax, updates one d_x entry per (segment, column)
  const Cost c{kF32 * 4.0 * kSegments * HF, 1.0 * kSegments * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::segment_max_backward(m.d_seg, argmax, d_x); });
}
BENCHMARK(segment_max_bwd)->Apply(mesh_sizes);

void broadcast_segments_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(m.n(), HF);
  const Cost c{kF32 * (1.0 * kSegments * HF + m.N() * HF), 0, m.n()};
  gatbench::run(state, c, [&] { cpu::broadcast_segments_forward(m.d_seg, m.seg_ptr, out); });
}
BENCHMARK(broadcast_segments_fwd)->Apply(mesh_sizes);

void broadcast_segments_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_x = Tensor::zeros(kSegments, HF);
  const Cost c{kF32 * (m.N() * HF + 2.0 * kSegments * HF), m.N() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::broadcast_segments_backward(m.d_out, m.seg_ptr, d_x); });
}
BENCHMARK(broadcast_segments_bwd)->Apply(mesh_sizes);

void neighbour_mean_fwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor out = Tensor::empty(m.n(), HF);
  const double En = static_cast<double>(m.nbr.num_edges());
  const Cost c{gatbench::csr_bytes(m.nbr) + kF32 * 2 * m.N() * HF, En * HF + m.N() * HF, m.n()};
  gatbench::run(state, c, [&] { cpu::neighbour_mean_forward(m.nbr, m.z, out); });
}
BENCHMARK(neighbour_mean_fwd)->Apply(mesh_sizes);

void neighbour_mean_bwd(benchmark::State& state) {
  const MeshCase& m = setup(state);
  Tensor d_x = Tensor::zeros(m.n(), HF);
  const double En = static_cast<double>(m.nbr.num_edges());
  // gathers over the transpose; needs each destination's degree (indptr)
  const Cost c{gatbench::transpose_bytes(m.nbr) + 8.0 * (m.N() + 1) + kF32 * 3 * m.N() * HF, 2 * En * HF,
               m.n()};
  gatbench::run(state, c, [&] { cpu::neighbour_mean_backward(m.nbr, m.d_out, d_x); });
}
BENCHMARK(neighbour_mean_bwd)->Apply(mesh_sizes);

// ---- GEMM on the model's layer shapes ----------------------------------------------------------------
// Args: M (rows = nodes), K (input width), N (output width), which product:
// (2048^3 and 4096^3 are the large square products that state the machine's GEMM rate)
//   0 fwd: C[M,N]  = A[M,K] B[K,N]
//   1 dA:  dA[M,K] += dC[M,N] B^T    (input gradient)
//   2 dB:  dB[K,N] += A^T dC[M,N]     (weight gradient)
struct GemmCase {
  Tensor A, B, C, dC, dA, dB;
};

void gemm_at(benchmark::State& state, Precision precision) {
  const std::int64_t M = state.range(0), K = state.range(1), N = state.range(2);
  const int which = static_cast<int>(state.range(3));
  const GemmCase& g = gatbench::cached<GemmCase>(std::vector<std::int64_t>{M, K, N}, [&] {
    GemmCase x;
    x.A = gatbench::random_tensor(M, K, 21);
    x.B = gatbench::random_tensor(K, N, 22);
    x.C = Tensor::empty(M, N);
    x.dC = gatbench::random_tensor(M, N, 23);
    x.dA = Tensor::zeros(M, K);
    x.dB = Tensor::zeros(K, N);
    return x;
  });
  const double m = static_cast<double>(M), k = static_cast<double>(K), n = static_cast<double>(N);
  static const char* names[] = {"fwd C=AB", "dA+=dC B^T", "dB+=A^T dC"};
  state.SetLabel(names[which]);
  // inputs read once, output written once (and read too when accumulating)
  const double bytes = which == 0   ? kF32 * (m * k + k * n + m * n)
                       : which == 1 ? kF32 * (m * n + k * n + 2 * m * k)
                                    : kF32 * (m * k + m * n + 2 * k * n);
  const Cost c{bytes, 2 * m * k * n, M};
  switch (which) {
    case 0: gatbench::run(state, c, [&] { cpu::gemm(g.A, false, g.B, false, g.C, 1.0f, 0.0f, precision); }); break;
    case 1: gatbench::run(state, c, [&] { cpu::gemm(g.dC, false, g.B, true, g.dA, 1.0f, 1.0f, precision); }); break;
    default: gatbench::run(state, c, [&] { cpu::gemm(g.A, true, g.dC, false, g.dB, 1.0f, 1.0f, precision); }); break;
  }
}
void gemm(benchmark::State& state) { gemm_at(state, Precision::fp32); }
// The training products in bf16 (gemm(..., Precision::bf16): operands rounded
// and packed per call, VDPBF16PS; the portable emulation, slow, on CPUs
// without AVX512_BF16). Compare with gemm/ of the same arguments.
void gemm_bf16(benchmark::State& state) { gemm_at(state, Precision::bf16); }
void gemm_shapes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"M", "K", "N", "op"})
      ->ArgsProduct({{8000}, {504}, {512}, {0, 1, 2}})
      ->ArgsProduct({{8000}, {392}, {64}, {0, 1, 2}})
      ->ArgsProduct({{8000}, {504}, {8}, {0, 1, 2}})       // the self-reinforced stream of a GAT block
      ->ArgsProduct({{24576}, {1088}, {1024}, {0, 1, 2}})  // NeuroSkinning's classifier input layer (12 x 2048)
      ->Args({2048, 2048, 2048, 0})                        // large squares: the machine's sgemm rate
      ->Args({4096, 4096, 4096, 0})
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond);
}
BENCHMARK(gemm)->Apply(gemm_shapes);
BENCHMARK(gemm_bf16)->Apply(gemm_shapes);

// The deploy path's forward products with pre-packed weights
// (gemm_prepacked.hpp): C[M,N] = A[M,K] B[K,N], precision 0 = fp32 (gemm()'s
// kernel, B packed once), 1 = bf16 (AVX512_BF16 where the CPU has it, else
// the portable emulation: slow). Compare with gemm/.../op:0.
void gemm_prepacked(benchmark::State& state) {
  const std::int64_t M = state.range(0), K = state.range(1), N = state.range(2);
  const Precision p = state.range(3) ? Precision::bf16 : Precision::fp32;
  const Tensor A = gatbench::random_tensor(M, K, 21), C = Tensor::empty(M, N);
  const cpu::PrepackedB B = cpu::prepack_b(gatbench::random_tensor(K, N, 22), p);
  const double m = static_cast<double>(M), k = static_cast<double>(K), n = static_cast<double>(N);
  state.SetLabel(std::string(gatcore::precision_name(p)) + (p == Precision::bf16 && !gatcore::bf16_supported() ? " (emulated)" : ""));
  gatbench::run(state, Cost{kF32 * (m * k + m * n), 2 * m * k * n, M}, [&] { cpu::gemm_prepacked(A, B, C); });
}
BENCHMARK(gemm_prepacked)
    ->ArgNames({"M", "K", "N", "bf16"})
    ->ArgsProduct({{10000}, {392}, {72}, {0, 1}})  // a GAT block's product (paper size, mid module): W | self_W
    ->ArgsProduct({{10000}, {504}, {512}, {0, 1}})  // the head's first layer
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace
