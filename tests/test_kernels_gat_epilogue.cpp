// gat_epilogue_bf16 (kernels/gat_epilogue_bf16.hpp) against the composition
// it replaces on the bf16 deploy path: the attention and self streams copied
// side by side, add_row_bias on the self columns,
// activation_forward tanhshrink, batchnorm_affine_forward, bf16_pairs.
// Bitwise, on odd widths, with and without the affine map and the self
// stream, strided input, 1 and 2 threads. AVX512_BF16 CPUs only.
#include <catch2/catch.hpp>

#include <cstring>

#include "gatcore/precision.hpp"
#include "kernels/batchnorm.hpp"
#include "kernels/elementwise.hpp"
#include "kernels/gat_epilogue_bf16.hpp"
#include "kernels/gat_fused.hpp"
#include "kernels/gemm_prepacked.hpp"
#include "reference/nn_reference.hpp"
#include "test_util.hpp"

using namespace gatcore;
using namespace gatcore::testutil;

TEST_CASE("gat_epilogue_bf16 equals add_row_bias + tanhshrink + batchnorm_affine_forward + bf16_pairs bitwise",
          "[gat_epilogue]") {
  if (!bf16_supported()) {
    WARN("SKIPPED: this CPU has no AVX512_BF16 (the kernel's only users run there)");
    CHECK_THROWS_WITH(cpu::gat_epilogue_bf16(Tensor::zeros(2, 4), Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor{}, nullptr, 2),
                      Catch::Contains("AVX512_BF16"));
    return;
  }
  Rng rng(41);
  struct Case {
    std::int64_t n, W, self0;
  };
  for (const Case& k : {Case{300, 72, 64}, Case{37, 33, 30}, Case{5, 8, 0}, Case{9, 1, 1}, Case{130, 40, 40},
                        Case{64, 64, 64}, Case{11, 47, 17}, Case{50, 100, 90}, Case{20, 130, 128}})
    for (bool affine : {true, false})
      for (int threads : {1, 2}) {
        Threads t(threads);
        INFO("n " << k.n << " W " << k.W << " self from " << k.self0 << " affine " << affine << " threads " << threads);
        const Tensor both = random(rng, k.n, k.W, true, -3.f, 3.f);
        const Tensor bias = k.W > k.self0 ? random(rng, 1, k.W - k.self0, false) : Tensor{};
        Tensor mean, scale, shift;
        if (affine) {
          mean = random(rng, 1, k.W, false, -0.5f, 0.5f);
          scale = random(rng, 1, k.W, false, 0.5f, 2.f);
          shift = random(rng, 1, k.W, false);
        }
        // The composition.
        Tensor x = both.clone(), y = Tensor::empty(k.n, k.W), z = Tensor::empty(k.n, k.W);
        if (bias.defined()) cpu::add_row_bias(bias, x.cols_slice(k.self0, k.W));
        cpu::activation_forward(Activation::tanhshrink, x, y, 0.f);
        if (affine) cpu::batchnorm_affine_forward(y, mean, scale, shift, z);
        const std::int64_t ld = (k.W + 1) / 2 + 2;
        std::vector<std::uint32_t> want(std::size_t(k.n * ld), 0xABCDu), got(want.size(), 0xABCDu);
        cpu::bf16_pairs(affine ? z : y, want.data(), ld);
        cpu::gat_epilogue_bf16(both.cols_slice(0, k.self0), k.W > k.self0 ? both.cols_slice(k.self0, k.W) : Tensor{},
                               bias, mean, scale, shift, got.data(), ld);
        std::size_t bad = 0;
        for (std::int64_t r = 0; r < k.n; ++r)
          for (std::int64_t w = 0; w < ld; ++w) bad += want[std::size_t(r * ld + w)] != got[std::size_t(r * ld + w)];
        CHECK(bad == 0);  // the padding words past the row untouched too
      }
}

// gat_attention_epilogue_bf16: the attention computed row chunk by row chunk
// and finished by the epilogue while in L1, against gat_fused_additive_forward
// followed by gat_epilogue_bf16: bitwise, for the 8 x 8 register path and a
// generic head shape, with and without self stream and affine map, 1 and 2
// threads (the graph is large enough to run in parallel).
TEST_CASE("gat_attention_epilogue_bf16 equals gat_fused_additive_forward + gat_epilogue_bf16 bitwise",
          "[gat_epilogue]") {
  if (!bf16_supported()) {
    WARN("SKIPPED: this CPU has no AVX512_BF16 (the kernel's only users run there)");
    return;
  }
  Rng rng(43);
  const CsrGraph g = ::testutil::random_graph(700, 7, {.min_degree = 2, .max_degree = 9});
  const std::int64_t n = g.num_nodes, E = g.num_edges();
  struct Case {
    int H, F;
    std::int64_t S;
  };
  for (const Case& k : {Case{8, 8, 8}, Case{8, 8, 0}, Case{3, 5, 4}, Case{2, 4, 3}})
    for (bool affine : {true, false})
      for (int threads : {1, 2}) {
        Threads t(threads);
        const std::int64_t kf = std::int64_t(k.H) * k.F, W = kf + k.S;
        INFO("H " << k.H << " F " << k.F << " self " << k.S << " affine " << affine << " threads " << threads);
        const Tensor zs = random(rng, n, W, true, -2.f, 2.f);
        const Tensor z = zs.cols_slice(0, kf), self = k.S ? zs.cols_slice(kf, W) : Tensor{};
        const Tensor el = random(rng, n, k.H, false, -3.f, 3.f), er = random(rng, n, k.H, false, -3.f, 3.f);
        const Tensor bias = k.S ? random(rng, 1, k.S, false) : Tensor{};
        Tensor mean, scale, shift;
        if (affine) {
          mean = random(rng, 1, W, false, -0.5f, 0.5f);
          scale = random(rng, 1, W, false, 0.5f, 2.f);
          shift = random(rng, 1, W, false);
        }
        Tensor att = Tensor::empty(n, kf), alpha = Tensor::empty(E, k.H);
        cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, att, alpha);
        const std::int64_t ld = (W + 1) / 2 + 3;
        std::vector<std::uint32_t> want(std::size_t(n * ld), 0xABCDu), got(want.size(), 0xABCDu);
        cpu::gat_epilogue_bf16(att, self, bias, mean, scale, shift, want.data(), ld);
        Tensor scratch = Tensor::empty(E, k.H);
        cpu::gat_attention_epilogue_bf16(g, z, el, er, 0.2f, scratch, self, bias, mean, scale, shift, got.data(), ld);
        CHECK(want == got);  // the padding words past each row untouched too
      }
  CHECK_THROWS_WITH(cpu::gat_attention_epilogue_bf16(g, Tensor::zeros(n, 64), Tensor::zeros(n, 8), Tensor::zeros(n, 8),
                                                     0.2f, Tensor::zeros(E, 8), Tensor::zeros(n, 8), Tensor{}, Tensor{},
                                                     Tensor{}, Tensor{}, nullptr, 36),
                    Catch::Contains("gat_attention_epilogue_bf16: no destination"));
}
