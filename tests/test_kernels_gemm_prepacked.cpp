// The inference GEMM with pre-packed weights (src/backends/cpu/inference.hpp):
// fp32 equals gemm() bitwise; bf16 (kernels/gemm_bf16.hpp) against a double
// reference of the bf16-rounded operands, through the portable emulation on
// every CPU and through the AVX512_BF16 kernel where the CPU has it; the
// rounding itself against VCVTNE2PS2BF16 bit for bit (on such CPUs). Odd
// shapes (k odd: a half-empty last pair; n around the 16 .. 80 panel widths
// and the 512 column block; m around the 120-row blocks and the 5 .. 24-row
// register tiles), strided A, 1 vs 2 threads.
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "src/backends/cpu/elementwise.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/gemm_bf16.hpp"
#include "src/backends/cpu/inference.hpp"
#include "src/backends/cpu/simd.hpp"
#include "reference/bf16_reference.hpp"
#include "reference/nn_reference.hpp"

using namespace gatcore;
using namespace gatcore::testutil;
using ref::Mat;

namespace {

struct Mkn {
  std::int64_t m, k, n;
};
const Mkn kShapes[] = {{1, 1, 1},     {5, 3, 2},     {37, 17, 8},   {121, 193, 16}, {250, 385, 17},
                       {130, 64, 64}, {241, 129, 3}, {13, 600, 33}, {300, 500, 520}, {49, 770, 72},
                       {21, 50, 40},  {97, 131, 80}, {26, 64, 81},  {125, 390, 100}, {60, 300, 64}, {50, 513, 128}};

bool same_bits(const Tensor& a, const Tensor& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  for (std::int64_t r = 0; r < a.rows(); ++r)
    if (std::memcmp(a.row(r), b.row(r), sizeof(float) * std::size_t(a.cols())) != 0) return false;
  return true;
}

}  // namespace

TEST_CASE("gemm_prepacked fp32: equals gemm() bitwise, at every SIMD level and thread count", "[gemm_prepacked]") {
  Rng rng(31);
  for (const Mkn& s : kShapes)
    for (bool strided : {false, true}) {
      const Tensor A = random(rng, s.m, s.k, strided), B = random(rng, s.k, s.n, false);
      const cpu::PrepackedB P = cpu::prepack_b(B, Precision::fp32);
      for (auto level : simd_levels()) {
        Simd simd(level);
        Tensor want = Tensor::empty(s.m, s.n);
        cpu::gemm(A, false, B, false, want);
        for (int threads : {1, 2}) {
          Threads t(threads);
          Tensor got = Tensor::full(s.m, s.n, std::numeric_limits<float>::quiet_NaN());  // every entry written
          cpu::gemm_prepacked(A, P, got);
          INFO("m " << s.m << " k " << s.k << " n " << s.n << " strided " << strided << " level "
                    << cpu::simd_level_name(level) << " threads " << threads);
          REQUIRE(same_bits(got, want));
        }
      }
    }
}

TEST_CASE("bf16 rounding: nearest even, denormals to signed zero, NaN quiet, overflow to infinity", "[gemm_prepacked]") {
  auto bits = [](std::uint32_t u) {
    float x;
    std::memcpy(&x, &u, 4);
    return cpu::bf16_bits(x);
  };
  CHECK(bits(0x3F800000u) == 0x3F80);  // 1
  CHECK(bits(0x3F808000u) == 0x3F80);  // tie, even below: down
  CHECK(bits(0x3F818000u) == 0x3F82);  // tie, odd below: up
  CHECK(bits(0x3F808001u) == 0x3F81);  // above the tie: up
  CHECK(bits(0x3F807FFFu) == 0x3F80);  // below the tie: down
  CHECK(bits(0xBF818000u) == 0xBF82);  // sign carried
  CHECK(bits(0x00000001u) == 0x0000);  // denormal -> +0
  CHECK(bits(0x807FFFFFu) == 0x8000);  // denormal -> -0
  CHECK(bits(0x7F7FFFFFu) == 0x7F80);  // largest float rounds to infinity
  CHECK(bits(0xFF800000u) == 0xFF80);  // -infinity
  CHECK(bits(0x7F800001u) == 0x7FC0);  // signalling NaN -> quiet
  CHECK(cpu::bf16_round(3.0f) == 3.0f);
  CHECK(cpu::bf16_round(1.0f + 1.0f / 256) == 1.0f);  // 2^-8 below bf16's resolution at 1: ties to even
}

TEST_CASE("bf16 rounding: the portable rounding is VCVTNE2PS2BF16's bit for bit (AVX512_BF16 CPUs)",
          "[gemm_prepacked]") {
  if (!cpu::detail::cpu_has_avx512_bf16()) {
    WARN("SKIPPED: this CPU has no AVX512_BF16; the hardware rounding is not checked here");
    return;
  }
  std::mt19937 rng(7);
  std::vector<float> x(100003);
  for (std::size_t i = 0; i < x.size(); ++i) {
    std::uint32_t u = rng();
    if (i % 7 == 0) u = (u & 0x8001FFFFu) | 0x3F800000u | (i % 3 == 0 ? 0x8000u : 0u);  // near-ties around 1
    if (i % 11 == 0) u &= 0x807FFFFFu;                                                // denormals
    if (i % 13 == 0) u |= 0x7F800000u;                                                // inf / NaN
    std::memcpy(&x[i], &u, 4);
  }
  std::vector<std::uint16_t> hw(x.size());
  cpu::detail::bf16_convert_avx512(x.data(), std::int64_t(x.size()), hw.data());
  std::size_t bad = 0, first = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (hw[i] != cpu::bf16_bits(x[i]) && bad++ == 0) first = i;
  INFO("first mismatch at " << first << ": hardware " << hw[first] << ", portable " << cpu::bf16_bits(x[first]));
  CHECK(bad == 0);
}

TEST_CASE("gemm_prepacked bf16: portable and AVX512_BF16 products against the double product of the rounded operands",
          "[gemm_prepacked]") {
  // Both operands are rounded to bf16 (exactly as the reference rounds them);
  // the products of two bf16 values are exact in fp32, so the only error left
  // is the fp32 accumulation: |error| <= k u sum |a b| (u = 2^-24, the
  // classical bound for any summation order).
  Rng rng(32);
  const bool hw = cpu::detail::cpu_has_avx512_bf16() && cpu::detected_simd_level() == cpu::SimdLevel::avx512;
  if (!hw) WARN("this CPU has no AVX512_BF16: only the portable bf16 product is checked");
  for (const Mkn& s : kShapes)
    for (bool strided : {false, true}) {
      const Tensor A = random(rng, s.m, s.k, strided), B = random(rng, s.k, s.n, false);
      const cpu::PrepackedB P = cpu::prepack_b(B, Precision::bf16);
      Mat bound;
      const Mat want = ref::gemm(ref::rounded_bf16(A), false, ref::rounded_bf16(B), false, Mat(s.m, s.n), 1.0, 0.0, &bound);
      const double rel = double(s.k) * std::ldexp(1.0, -24) * 1.001;
      std::vector<cpu::SimdLevel> levels = {cpu::SimdLevel::scalar};  // below AVX-512: the portable product
      if (hw) levels.push_back(cpu::SimdLevel::avx512);
      for (auto level : levels) {
        Simd simd(level);
        Tensor one;
        for (int threads : {1, 2}) {
          Threads t(threads);
          Tensor got = Tensor::full(s.m, s.n, std::numeric_limits<float>::quiet_NaN());
          cpu::gemm_prepacked(A, P, got);
          const std::string what = "bf16 m " + std::to_string(s.m) + " k " + std::to_string(s.k) + " n " +
                                   std::to_string(s.n) + " strided " + std::to_string(strided) + " " +
                                   cpu::simd_level_name(level) + " threads " + std::to_string(threads);
          require_close_bound(got, want, bound, rel, 1e-30, what);
          if (threads == 1)
            one = got;
          else
            REQUIRE(same_bits(got, one));  // no dependence on the thread count
        }
      }
    }
}

TEST_CASE("gemm_prepacked bf16: pre-converted bf16 rows give the float A's product bitwise", "[gemm_prepacked]") {
  Rng rng(33);
  for (const Mkn& s : kShapes)
    for (auto level : simd_levels()) {
      Simd simd(level);
      const Tensor A = random(rng, s.m, s.k, true), B = random(rng, s.k, s.n, false);
      const cpu::PrepackedB P = cpu::prepack_b(B, Precision::bf16);
      const std::int64_t ld = (s.k + 1) / 2 + 3;  // a row stride wider than the row
      std::vector<std::uint32_t> words(std::size_t((s.m + 24) * ld), 0xFFFFFFFFu);  // padding rows: NaN pairs
      cpu::bf16_pairs(A, words.data(), ld);
      std::int64_t bad = 0;  // halves that are not bf16_bits of A's value (or 0 past an odd k)
      for (std::int64_t i = 0; i < s.m; ++i) {
        for (std::int64_t kk = 0; kk < s.k; ++kk) {
          const std::uint32_t w = words[std::size_t(i * ld + kk / 2)];
          bad += std::uint16_t(kk % 2 ? w >> 16 : w & 0xFFFFu) != cpu::bf16_bits(A.at(i, kk));
        }
        if (s.k % 2) bad += words[std::size_t(i * ld + s.k / 2)] >> 16 != 0u;
      }
      REQUIRE(bad == 0);
      Tensor want = Tensor::empty(s.m, s.n), got = Tensor::empty(s.m, s.n);
      cpu::gemm_prepacked(A, P, want);
      cpu::gemm_prepacked(cpu::Bf16Rows{words.data(), s.m, s.k, ld}, P, got);
      INFO("m " << s.m << " k " << s.k << " n " << s.n << " level " << cpu::simd_level_name(level));
      REQUIRE(same_bits(got, want));
    }
  const cpu::PrepackedB F = cpu::prepack_b(Tensor::full(4, 3, 1.0f), Precision::fp32);
  std::vector<std::uint32_t> w(48, 0);
  CHECK_THROWS_WITH(cpu::gemm_prepacked(cpu::Bf16Rows{w.data(), 2, 4, 2}, F, Tensor::empty(2, 3)),
                    Catch::Contains("need a B packed in bf16"));
}

TEST_CASE("gemm_prepacked_bias_act_bf16: the composition gemm_prepacked + add_row_bias + activation + bf16_pairs bitwise",
          "[gemm_prepacked]") {
  const bool hw = bf16_supported();
  std::vector<std::uint32_t> w0(64, 0);
  const cpu::PrepackedB P0 = cpu::prepack_b(Tensor::full(4, 3, 1.0f), Precision::bf16);
  if (!hw) {
    WARN("SKIPPED: this CPU has no AVX512_BF16 (the kernel's only user, the bf16 deploy path, runs there)");
    CHECK_THROWS_WITH(cpu::gemm_prepacked_bias_act_bf16(cpu::Bf16Rows{w0.data(), 2, 4, 2}, P0, Tensor{},
                                                        Activation::tanh, Tensor::empty(2, 3), w0.data(), 2),
                      Catch::Contains("AVX512_BF16"));
    return;
  }
  Rng rng(35);
  // k 770, 1600: two and three k blocks (partial sums through C); n 520: two column blocks.
  const Mkn shapes[] = {{1, 1, 1},    {37, 17, 8},   {250, 385, 17}, {241, 129, 3},   {300, 500, 520},
                        {49, 770, 72}, {97, 131, 80}, {26, 64, 81},   {125, 390, 100}, {130, 1600, 33}};
  for (const Mkn& s : shapes)
    for (Activation act : {Activation::tanh, Activation::identity})
      for (bool bias_on : {true, false})
        for (int threads : {1, 2}) {
          Threads t(threads);
          INFO("m " << s.m << " k " << s.k << " n " << s.n << " " << activation_name(act) << " bias " << bias_on
                    << " threads " << threads);
          const Tensor A = random(rng, s.m, s.k, true, -2.f, 2.f), B = random(rng, s.k, s.n, false, -0.2f, 0.2f);
          const Tensor bias = bias_on ? random(rng, 1, s.n, false) : Tensor{};
          const cpu::PrepackedB P = cpu::prepack_b(B, Precision::bf16);
          const std::int64_t lda = (s.k + 1) / 2 + 1, ld = (s.n + 1) / 2 + 2;
          std::vector<std::uint32_t> aw(std::size_t((s.m + 24) * lda), 0u);
          cpu::bf16_pairs(A, aw.data(), lda);
          const cpu::Bf16Rows rows{aw.data(), s.m, s.k, lda};
          // The composition.
          Tensor c = Tensor::empty(s.m, s.n), y = Tensor::empty(s.m, s.n);
          cpu::gemm_prepacked(rows, P, c);
          if (bias_on) cpu::add_row_bias(bias, c);
          if (act == Activation::tanh)
            cpu::activation_forward(act, c, y, 0.f);
          else
            y = c;
          std::vector<std::uint32_t> want(std::size_t(s.m * ld), 0xABCDu), got(want.size(), 0xABCDu);
          cpu::bf16_pairs(y, want.data(), ld);
          Tensor scratch = Tensor::full(s.m, s.n, std::numeric_limits<float>::quiet_NaN());
          cpu::gemm_prepacked_bias_act_bf16(rows, P, bias, act, scratch, got.data(), ld);
          CHECK(got == want);  // the words past each row untouched too
        }
  CHECK_THROWS_WITH(cpu::gemm_prepacked_bias_act_bf16(cpu::Bf16Rows{w0.data(), 2, 4, 2}, P0, Tensor{},
                                                      Activation::relu, Tensor::empty(2, 3), w0.data(), 2),
                    Catch::Contains("identity or tanh"));
  CHECK_THROWS_WITH(cpu::gemm_prepacked_bias_act_bf16(cpu::Bf16Rows{w0.data(), 2, 4, 2}, P0, Tensor{},
                                                      Activation::tanh, Tensor::empty(2, 3), w0.data(), 1),
                    Catch::Contains("below 2 words"));
}

// The sink of every A form: bf16 rows, and a float A with an fp32 or bf16
// packed B, at the active SIMD level and at the scalar level (where the
// fp32 product runs gemm() and hands the blocks out afterwards).
TEST_CASE("gemm_prepacked with a row-block sink: each block once, after its rows are final", "[gemm_prepacked]") {
  Rng rng(37);
  struct Seen {
    const Tensor* c;
    const Tensor* want;
    std::vector<int> rows;
    std::atomic<int> bad{0};
  };
  const cpu::RowBlockSink sink = [](void* ctx, std::int64_t i0, std::int64_t n) {
    Seen& z = *static_cast<Seen*>(ctx);
    for (std::int64_t i = i0; i < i0 + n; ++i) {
      ++z.rows[std::size_t(i)];  // blocks are disjoint: no two threads write one entry
      if (std::memcmp(z.c->row(i), z.want->row(i), sizeof(float) * std::size_t(z.c->cols())) != 0) ++z.bad;
    }
  };
  const cpu::SimdLevel active = cpu::simd_level();  // GATCORE_SIMD may have set it
  enum class Form { bf16_rows, f32_a_f32_b, f32_a_bf16_b };
  for (const cpu::SimdLevel level : {active, cpu::SimdLevel::scalar})
    for (const Form form : {Form::bf16_rows, Form::f32_a_f32_b, Form::f32_a_bf16_b})
      for (const Mkn& s : {Mkn{1000, 130, 72}, Mkn{37, 17, 8}, Mkn{241, 0, 3}})
        for (int threads : {1, 2}) {
          Simd simd(level);
          Threads t(threads);
          INFO("level " << cpu::simd_level_name(level) << " form " << int(form) << " m " << s.m << " k " << s.k
                        << " n " << s.n << " threads " << threads);
          const Tensor A = random(rng, s.m, s.k, false), B = random(rng, s.k, s.n, false);
          const cpu::PrepackedB P = cpu::prepack_b(B, form == Form::f32_a_f32_b ? Precision::fp32 : Precision::bf16);
          const std::int64_t ld = (s.k + 1) / 2 + 1;
          std::vector<std::uint32_t> words(std::size_t((s.m + 24) * ld), 0u);
          cpu::bf16_pairs(A, words.data(), ld);
          const cpu::Bf16Rows rows{words.data(), s.m, s.k, ld};
          Tensor want = Tensor::empty(s.m, s.n), got = Tensor::full(s.m, s.n, std::numeric_limits<float>::quiet_NaN());
          Seen seen{&got, &want, std::vector<int>(std::size_t(s.m), 0), {}};
          if (form == Form::bf16_rows) {
            cpu::gemm_prepacked(rows, P, want);
            cpu::gemm_prepacked(rows, P, got, sink, &seen);
          } else {
            cpu::gemm_prepacked(A, P, want);
            cpu::gemm_prepacked(A, P, got, sink, &seen);
          }
          CHECK(seen.bad.load() == 0);  // the block's rows were final when the sink saw them
          CHECK(std::count(seen.rows.begin(), seen.rows.end(), 1) == s.m);
          CHECK(same_bits(got, want));
        }
}

TEST_CASE("gemm_prepacked bf16 is not fp32: a product that bf16 rounding changes", "[gemm_prepacked]") {
  // 1 + 2^-10 is not a bf16 value (8-bit mantissa): the bf16 product of
  // [1 + 2^-10] and [1] is 1, the fp32 product is not. Guards against a bf16
  // path that silently runs in fp32.
  Tensor A = Tensor::full(3, 1, 1.0f + 1.0f / 1024), B = Tensor::full(1, 2, 1.0f);
  Tensor C = Tensor::empty(3, 2);
  for (auto level : simd_levels()) {
    Simd simd(level);
    cpu::gemm_prepacked(A, cpu::prepack_b(B, Precision::bf16), C);
    CHECK(C.at(2, 1) == 1.0f);
    cpu::gemm_prepacked(A, cpu::prepack_b(B, Precision::fp32), C);
    CHECK(C.at(2, 1) == 1.0f + 1.0f / 1024);
  }
}

TEST_CASE("gemm_prepacked: shape errors name the operands, k = 0 gives zeros", "[gemm_prepacked]") {
  const cpu::PrepackedB P = cpu::prepack_b(Tensor::full(4, 3, 1.0f), Precision::fp32);
  Tensor C = Tensor::empty(2, 3);
  CHECK_THROWS_WITH(cpu::gemm_prepacked(Tensor::empty(2, 5), P, C), Catch::Contains("packed B has 4 rows"));
  CHECK_THROWS_WITH(cpu::gemm_prepacked(Tensor::empty(2, 4), P, Tensor::empty(2, 4)),
                    Catch::Contains("expected shape [2, 3]"));
  CHECK_THROWS_WITH(parse_precision("fp16", "--precision"), Catch::Contains("--precision: 'fp16'"));
  for (Precision p : {Precision::fp32, Precision::bf16}) {
    Tensor Z = Tensor::full(2, 3, 5.0f);
    cpu::gemm_prepacked(Tensor::empty(2, 0), cpu::prepack_b(Tensor::empty(0, 3), p), Z);
    CHECK(Z.at(1, 2) == 0.0f);
  }
}
