// Operands past the device's real maxStorageBufferRange (128 MiB on lavapipe):
// a graph kernel family (gathers from arbitrary neighbour rows of a feature
// matrix larger than one binding may cover) and GEMM (operands and the
// K-dimension past it), forward and backward, against the CPU kernels. Sized
// from the queried limit, just past it; run once (default lavapipe width)
// since each case moves ~0.5 GB. Every other op's large path is covered by the
// parity suite under the GATCORE_VK_MAX_BINDING_BYTES hook (*_smallbind).
//
// Hidden "[.nobda]" case: run by ctest with GATCORE_VK_NO_BDA=1 and the hook,
// it checks the behaviour of a device without bufferDeviceAddress.
#include <random>

#include "gatcore/graph.hpp"
#include "gradcheck.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using vkt::H;
using vkt::require_close;
using vkt::V;

namespace {

Backend& cpu() { return backend(Device::cpu); }
Backend& gpu() { return backend(Device::vulkan); }

// The binding range the backend uses, or 0 (test skipped, said so) when it is
// too large for a CI-sized test (real GPUs typically allow 2-4 GiB).
std::uint64_t binding_range() {
  const auto d = vulkan::current_device();
  if (d.binding_range > (std::uint64_t{512} << 20)) {
    WARN("SKIPPED: " << d.name << " binds " << d.binding_range << " bytes; a tensor past that is too big here");
    return 0;
  }
  return d.binding_range;
}

}  // namespace

TEST_CASE("vulkan: graph attention with features past maxStorageBufferRange", "[vulkan][large]") {
  if (!vkt::ready()) return;
  const std::uint64_t L = binding_range();
  if (!L) return;
  std::mt19937 rng(11);
  // Row i gathers from rows i+1, n-1-i and a pseudo-random one, so every
  // gather reaches across the whole feature matrix; node 5 is isolated.
  const std::int64_t n = 2048;
  std::vector<std::int32_t> src, dst;
  for (std::int32_t i = 0; i < n; ++i) {
    if (i == 5) continue;
    for (std::int64_t j : {(i + 1) % n, n - 1 - i, (i * 977 + 31) % n}) {
      src.push_back(static_cast<std::int32_t>(j));
      dst.push_back(i);
    }
  }
  const CsrGraph g = graph_from_edges(n, src, dst);
  const std::int64_t E = g.num_edges();
  const auto bda0 = vulkan::stats().bda_dispatches;
  const std::uint64_t limit = vulkan::current_device().max_storage_buffer_range;

  SECTION("aggregation over a dense feature matrix past the limit") {
    // z and out [n, 2 heads x F]: each just past the limit.
    const std::int64_t Hh = 2, F = static_cast<std::int64_t>(L / (4 * n * Hh)) + 64, C = Hh * F;
    REQUIRE(static_cast<std::uint64_t>(n * C * 4) > limit);
    Tensor z = gradcheck::random_tensor(n, C, rng), alpha = gradcheck::random_tensor(E, Hh, rng, 0.f, 1.f);
    Tensor outc = Tensor::empty(n, C), outg = gpu().empty(n, C, DType::f32);
    cpu().aggregate_forward(g, alpha, z, outc);
    gpu().aggregate_forward(g, V(alpha), V(z), outg);
    require_close(outc, outg, 1e-4f, 1e-5f, "aggregate_forward");
  }
  SECTION("attention, softmax, aggregation and fused GAT over views spanning past the limit") {
    // Feature views [n, H*F] whose rows lie in wide buffers (ld past L / 4n):
    // each view spans more than the limit, so its rows are reached past
    // 128 MiB, at the cost of a narrow tensor.
    const std::int64_t Hh = 2, F = 24, C = Hh * F, ld = static_cast<std::int64_t>(L / (4 * n)) + 64;
    auto wide = [&](const Tensor& host) {
      Tensor buf = gpu().empty(n, ld, DType::f32);
      Tensor view = buf.cols_slice(ld - C, ld);
      gpu().copy(V(host), view);
      return view;
    };
    Tensor z = gradcheck::random_tensor(n, C, rng), d_out = gradcheck::random_tensor(n, C, rng);
    Tensor zg = wide(z), d_outg = wide(d_out);
    REQUIRE(static_cast<std::uint64_t>(((n - 1) * ld + C) * 4) > limit);
    Tensor al = gradcheck::random_tensor(Hh, F, rng), ar = gradcheck::random_tensor(Hh, F, rng);
    // projection forward / backward
    Tensor elc = Tensor::empty(n, Hh), erc = Tensor::empty(n, Hh);
    Tensor elg = gpu().empty(n, Hh, DType::f32), erg = gpu().empty(n, Hh, DType::f32);
    cpu().attention_projection_forward(z, al, ar, elc, erc);
    gpu().attention_projection_forward(zg, V(al), V(ar), elg, erg);
    require_close(elc, elg, 1e-4f, 1e-5f, "projection el");
    require_close(erc, erg, 1e-4f, 1e-5f, "projection er");
    Tensor del = gradcheck::random_tensor(n, Hh, rng), der = gradcheck::random_tensor(n, Hh, rng);
    {
      Tensor dzc = z.clone(), dzg = wide(z), dalc = Tensor::zeros(Hh, F), dalg = gpu().zeros(Hh, F, DType::f32);
      cpu().attention_projection_backward(z, al, ar, del, der, dzc, dalc, Tensor());
      gpu().attention_projection_backward(zg, V(al), V(ar), V(del), V(der), dzg, dalg, Tensor());
      require_close(dzc, dzg, 1e-4f, 1e-5f, "projection d_z");
      require_close(dalc, dalg, 1e-4f, 1e-4f, "projection d_al");
    }
    // additive edge softmax + aggregation forward / backward
    Tensor ac = Tensor::empty(E, Hh), ag = gpu().empty(E, Hh, DType::f32);
    cpu().edge_softmax_additive_forward(g, elc, erc, 0.2f, ac);
    gpu().edge_softmax_additive_forward(g, elg, erg, 0.2f, ag);
    require_close(ac, ag, 1e-4f, 1e-6f, "edge_softmax_additive_forward");
    {
      Tensor outc = Tensor::empty(n, C), outg = wide(z);
      cpu().aggregate_forward(g, ac, z, outc);
      gpu().aggregate_forward(g, ag, zg, outg);
      require_close(outc, outg, 1e-4f, 1e-5f, "aggregate_forward");
      Tensor dac = Tensor::zeros(E, Hh), dzc = Tensor::zeros(n, C);
      Tensor dag = gpu().zeros(E, Hh, DType::f32), dzg = wide(Tensor::zeros(n, C));
      cpu().aggregate_backward(g, ac, z, d_out, dac, dzc);
      gpu().aggregate_backward(g, ag, zg, d_outg, dag, dzg);
      require_close(dac, dag, 1e-4f, 1e-5f, "aggregate_backward d_alpha");
      require_close(dzc, dzg, 1e-4f, 1e-5f, "aggregate_backward d_z");
    }
    // fused dot-product attention forward / backward
    {
      const float scale = 0.2f;
      Tensor outc = Tensor::empty(n, C), fac = Tensor::empty(E, Hh);
      Tensor outg = wide(z), fag = gpu().empty(E, Hh, DType::f32);
      cpu().gat_fused_dot_forward(g, z, static_cast<int>(Hh), scale, outc, fac);
      gpu().gat_fused_dot_forward(g, zg, static_cast<int>(Hh), scale, outg, fag);
      require_close(fac, fag, 1e-4f, 1e-6f, "gat_fused_dot_forward alpha");
      require_close(outc, outg, 1e-4f, 1e-5f, "gat_fused_dot_forward out");
      Tensor dzc = Tensor::zeros(n, C), dzg = wide(Tensor::zeros(n, C));
      cpu().gat_fused_dot_backward(g, z, static_cast<int>(Hh), scale, fac, d_out, dzc);
      gpu().gat_fused_dot_backward(g, zg, static_cast<int>(Hh), scale, fag, d_outg, dzg);
      require_close(dzc, dzg, 1e-4f, 1e-5f, "gat_fused_dot_backward d_z");
    }
  }
  REQUIRE(vulkan::stats().bda_dispatches > bda0);
}

TEST_CASE("vulkan: GEMM with operands past maxStorageBufferRange", "[vulkan][large]") {
  if (!vkt::ready()) return;
  const std::uint64_t L = binding_range();
  if (!L) return;
  std::mt19937 rng(12);
  // A Linear layer over M rows: x [M, K] just past the limit.
  const std::int64_t K = 64, N = 8, M = static_cast<std::int64_t>(L / (4 * K)) + 1000;
  REQUIRE(static_cast<std::uint64_t>(M * K * 4) > vulkan::current_device().max_storage_buffer_range);
  const auto bda0 = vulkan::stats().bda_dispatches;
  Tensor x = gradcheck::random_tensor(M, K, rng), xg = V(x);
  Tensor W = gradcheck::random_tensor(N, K, rng), Wg = V(W);
  Tensor d_y = gradcheck::random_tensor(M, N, rng), d_yg = V(d_y);
  {  // y = x W^T
    Tensor yc = Tensor::empty(M, N), yg = gpu().empty(M, N, DType::f32);
    cpu().gemm(x, false, W, true, yc, 1.0f, 0.0f);
    gpu().gemm(xg, false, Wg, true, yg, 1.0f, 0.0f);
    require_close(yc, yg, 1e-4f, 1e-4f, "gemm y = x W^T");
  }
  {  // d_W += d_y^T x: the K-dimension of this product runs over all M rows of x.
    Tensor dW0 = gradcheck::random_tensor(N, K, rng);
    Tensor dWc = dW0.clone(), dWg = V(dW0);
    cpu().gemm(d_y, true, x, false, dWc, 1.0f, 1.0f);
    gpu().gemm(d_yg, true, xg, false, dWg, 1.0f, 1.0f);
    require_close(dWc, dWg, 1e-3f, 5e-2f, "gemm d_W = d_y^T x");  // sums of ~5e5 terms
  }
  {  // d_x = 0.5 d_x + d_y W: C past the limit, read (beta) and written.
    Tensor dx0 = x;  // any values
    Tensor dxc = dx0.clone(), dxg = xg.clone();
    cpu().gemm(d_y, false, W, false, dxc, 1.0f, 0.5f);
    gpu().gemm(d_yg, false, Wg, false, dxg, 1.0f, 0.5f);
    require_close(dxc, dxg, 1e-4f, 1e-4f, "gemm d_x = d_y W");
  }
  {  // Reductions over it: sum_all and column sums (bias gradients, BN statistics).
    Tensor sc = Tensor::empty(1, 1), sg = gpu().empty(1, 1, DType::f32);
    cpu().sum_all(x, sc);
    gpu().sum_all(xg, sg);
    require_close(sc, sg, 1e-3f, 1e-1f, "sum_all");
    Tensor cc = Tensor::zeros(1, K), cg = gpu().zeros(1, K, DType::f32);
    cpu().column_sums_accumulate(x, cc);
    gpu().column_sums_accumulate(xg, cg);
    require_close(cc, cg, 1e-3f, 5e-2f, "column_sums_accumulate");
  }
  REQUIRE(vulkan::stats().bda_dispatches > bda0);
}

TEST_CASE("vulkan: without bufferDeviceAddress, large operands chunk or fail clearly", "[.nobda]") {
  if (!vkt::ready()) return;
  const auto d = vulkan::current_device();
  REQUIRE_FALSE(d.buffer_device_address);
  REQUIRE(d.binding_range == 256);  // run with GATCORE_VK_MAX_BINDING_BYTES=256
  std::mt19937 rng(13);
  // Elementwise ops need no device feature: split into row chunks.
  Tensor x = gradcheck::random_tensor(64, 16, rng), y = gradcheck::random_tensor(64, 16, rng);
  Tensor yg = V(y);
  const auto s0 = vulkan::stats();
  gpu().axpy(0.5f, V(x), yg);
  REQUIRE(vulkan::stats().chunked_dispatches - s0.chunked_dispatches >= 2);
  cpu().axpy(0.5f, x, y);
  require_close(y, yg, 0, 0, "chunked axpy");
  // Other ops name the op, the operand and its size.
  Tensor C = gpu().zeros(64, 16, DType::f32);
  REQUIRE_THROWS_WITH(gpu().gemm(V(x), false, V(gradcheck::random_tensor(16, 16, rng)), false, C, 1.f, 0.f),
                      Catch::Contains("gemm: gemm: A spans 4096 bytes") && Catch::Contains("bufferDeviceAddress"));
  // So does an elementwise op whose single row exceeds the binding range.
  Tensor wide = gpu().empty(2, 100, DType::f32);
  REQUIRE_THROWS_WITH(gpu().fill(wide, 1.f), Catch::Contains("fill: a single row of tensor [2, 100]") &&
                                                 Catch::Contains("bufferDeviceAddress"));
}
