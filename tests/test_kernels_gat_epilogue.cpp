// gat_epilogue / gat_epilogue_bf16 (src/backends/cpu/inference.hpp) against the
// composition they replace on the deploy path: the attention and self
// streams copied side by side, add_row_bias on the self columns,
// activation_forward tanhshrink, batchnorm_affine_forward (and bf16_pairs).
// Bitwise, on odd widths, with and without the affine map and the self
// stream, strided input and output, 1 and 2 threads. fp32: the AVX-512 SIMD
// level; bf16: AVX512_BF16 CPUs.
#include <catch2/catch.hpp>

#include <cstring>

#include "gatcore/precision.hpp"
#include "src/backends/cpu/batchnorm.hpp"
#include "src/backends/cpu/elementwise.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/simd.hpp"
#include "reference/nn_reference.hpp"
#include "test_util.hpp"

using namespace gatcore;
using namespace gatcore::testutil;

namespace {

// The composition of the fp32 epilogue: [att | self] + bias on the self
// columns, tanhshrink, the affine map (if any).
Tensor composed(const Tensor& att, const Tensor& self, const Tensor& bias, const Tensor& mean, const Tensor& scale,
                const Tensor& shift) {
  const std::int64_t n = att.rows(), kf = att.cols(), W = kf + (self.defined() ? self.cols() : 0);
  Tensor x = Tensor::empty(n, W), y = Tensor::empty(n, W), z = Tensor::empty(n, W);
  x.cols_slice(0, kf).copy_from_(att);
  if (W > kf) {
    x.cols_slice(kf, W).copy_from_(self);
    if (bias.defined()) cpu::add_row_bias(bias, x.cols_slice(kf, W));
  }
  cpu::activation_forward(Activation::tanhshrink, x, y, 0.f);
  if (!mean.defined()) return y;
  cpu::batchnorm_affine_forward(y, mean, scale, shift, z);
  return z;
}

// Bitwise equality of two [n, W] views, and the guard columns of `wide` around
// `got` (got = wide.cols_slice(2, 2 + W)) still hold `fill`.
std::size_t mismatches(const Tensor& want, const Tensor& wide, std::int64_t W, float fill) {
  std::size_t bad = 0;
  for (std::int64_t r = 0; r < want.rows(); ++r)
    for (std::int64_t c = 0; c < wide.cols(); ++c) {
      const float g = wide.at(r, c);
      if (c >= 2 && c < 2 + W)
        bad += std::memcmp(&g, &want.row(r)[c - 2], sizeof g) != 0;
      else
        bad += g != fill;
    }
  return bad;
}

}  // namespace

TEST_CASE("gat_epilogue and gat_epilogue_bf16 refuse where they cannot run", "[gat_epilogue]") {
  {
    // Below AVX-512 both refuse, naming what is missing (the deploy path composes instead).
    Simd scalar(cpu::SimdLevel::scalar);
    CHECK_FALSE(cpu::gat_epilogue_supported());
    CHECK_THROWS_WITH(cpu::gat_epilogue(Tensor::zeros(2, 4), Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor{},
                                        Tensor::zeros(2, 4)),
                      Catch::Contains("gat_epilogue: needs the AVX-512 SIMD level (active: scalar)"));
    CHECK_THROWS_WITH(cpu::gat_epilogue_bf16(Tensor::zeros(2, 4), Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor{},
                                             nullptr, 2),
                      Catch::Contains("AVX512_BF16"));
  }
  if (!cpu::gat_epilogue_supported()) return;
  // Bad destinations name the argument.
  const Tensor a = Tensor::zeros(4, 8);
  CHECK_THROWS_WITH(cpu::gat_epilogue(a, Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor::zeros(4, 7)),
                    Catch::Contains("gat_epilogue: out"));
  CHECK_THROWS_WITH(cpu::gat_epilogue(a, Tensor{}, Tensor{}, Tensor{}, Tensor{}, Tensor{}, a),
                    Catch::Contains("overlaps an input"));
}

TEST_CASE("gat_epilogue(_bf16) equals add_row_bias + tanhshrink + batchnorm_affine_forward (+ bf16_pairs) bitwise",
          "[gat_epilogue]") {
  const bool f32 = cpu::gat_epilogue_supported(), bf16 = bf16_supported();
  if (!f32) WARN("SKIPPED fp32: this CPU has no AVX-512 (the deploy path composes the epilogue there)");
  if (!bf16) WARN("SKIPPED bf16: this CPU has no AVX512_BF16 (the kernel's only users run there)");
  if (!f32 && !bf16) return;
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
        const Tensor att = both.cols_slice(0, k.self0), self = k.W > k.self0 ? both.cols_slice(k.self0, k.W) : Tensor{};
        const Tensor bias = k.W > k.self0 ? random(rng, 1, k.W - k.self0, false) : Tensor{};
        Tensor mean, scale, shift;
        if (affine) {
          mean = random(rng, 1, k.W, false, -0.5f, 0.5f);
          scale = random(rng, 1, k.W, false, 0.5f, 2.f);
          shift = random(rng, 1, k.W, false);
        }
        const Tensor want = composed(att, self, bias, mean, scale, shift);
        if (f32) {  // strided destination with guard columns on both sides
          Tensor wide = Tensor::full(k.n, k.W + 5, 7.25f);
          cpu::gat_epilogue(att, self, bias, mean, scale, shift, wide.cols_slice(2, 2 + k.W));
          CHECK(mismatches(want, wide, k.W, 7.25f) == 0);
        }
        if (bf16) {
          const std::int64_t ld = (k.W + 1) / 2 + 2;
          std::vector<std::uint32_t> want_w(std::size_t(k.n * ld), 0xABCDu), got(want_w.size(), 0xABCDu);
          cpu::bf16_pairs(want, want_w.data(), ld);
          cpu::gat_epilogue_bf16(att, self, bias, mean, scale, shift, got.data(), ld);
          CHECK(want_w == got);  // the padding words past the row untouched too
        }
      }
}

// gat_attention_epilogue(_bf16): the attention computed row chunk by row
// chunk and finished by the epilogue while in L1, against
// gat_fused_additive_forward followed by the composition (fp32) and by
// gat_epilogue_bf16 (bf16): bitwise, for the 8 x 8 register path and a
// generic head shape, with and without self stream and affine map, 1 and 2
// threads (the graph is large enough to run in parallel).
TEST_CASE("gat_attention_epilogue(_bf16) equals gat_fused_additive_forward + the epilogue bitwise",
          "[gat_epilogue]") {
  const bool f32 = cpu::gat_epilogue_supported(), bf16 = bf16_supported();
  if (!f32) WARN("SKIPPED fp32: this CPU has no AVX-512 (the deploy path composes the epilogue there)");
  if (!bf16) WARN("SKIPPED bf16: this CPU has no AVX512_BF16 (the kernel's only users run there)");
  if (!f32 && !bf16) return;
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
        Tensor att = Tensor::empty(n, kf), alpha = Tensor::empty(E, k.H), scratch = Tensor::empty(E, k.H);
        cpu::gat_fused_additive_forward(g, z, el, er, 0.2f, att, alpha);
        if (f32) {
          const Tensor want = composed(att, self, bias, mean, scale, shift);
          Tensor wide = Tensor::full(n, W + 4, -1.5f);
          cpu::gat_attention_epilogue(g, z, el, er, 0.2f, scratch, self, bias, mean, scale, shift,
                                      wide.cols_slice(2, 2 + W));
          CHECK(mismatches(want, wide, W, -1.5f) == 0);
        }
        if (bf16) {
          const std::int64_t ld = (W + 1) / 2 + 3;
          std::vector<std::uint32_t> want(std::size_t(n * ld), 0xABCDu), got(want.size(), 0xABCDu);
          cpu::gat_epilogue_bf16(att, self, bias, mean, scale, shift, want.data(), ld);
          cpu::gat_attention_epilogue_bf16(g, z, el, er, 0.2f, scratch, self, bias, mean, scale, shift, got.data(),
                                           ld);
          CHECK(want == got);  // the padding words past each row untouched too
        }
      }
  if (f32)
    CHECK_THROWS_WITH(cpu::gat_attention_epilogue(g, Tensor::zeros(n, 64), Tensor::zeros(n, 8), Tensor::zeros(n, 8),
                                                  0.2f, Tensor::zeros(E, 8), Tensor::zeros(n, 8), Tensor{}, Tensor{},
                                                  Tensor{}, Tensor{}, Tensor::zeros(n, 71)),
                      Catch::Contains("gat_attention_epilogue: out"));
  if (bf16)
    CHECK_THROWS_WITH(cpu::gat_attention_epilogue_bf16(g, Tensor::zeros(n, 64), Tensor::zeros(n, 8),
                                                       Tensor::zeros(n, 8), 0.2f, Tensor::zeros(E, 8),
                                                       Tensor::zeros(n, 8), Tensor{}, Tensor{}, Tensor{}, Tensor{},
                                                       nullptr, 36),
                      Catch::Contains("gat_attention_epilogue_bf16: no destination"));
}
