// The bf16 training product (gemm(..., Precision::bf16), kernels/gemm_bf16_train.cpp)
// for the three cases training runs: A B (forward), dC B^T (input gradient),
// A^T dC (weight gradient, k over the batch rows). Against a double product of
// the bf16-rounded operands (the only error left is fp32 accumulation, k u
// sum |a b|), through the AVX512_BF16 kernel where the CPU has it and the
// portable emulation everywhere, the two bitwise equal; odd shapes (k = 1, k
// odd, k over the 768-deep chunks, several 1024 x 1024 tiles, a split k), strided
// views of A, B and C, beta = 0 over a NaN-filled C, alpha != 1, beta = 1;
// 1 vs 2 threads bitwise. And the per-call packing against pack_b_bf16.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "src/backends/cpu/elementwise.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/gemm_bf16.hpp"
#include "reference/bf16_reference.hpp"
#include "reference/nn_reference.hpp"

using namespace gatcore;
using namespace gatcore::testutil;
using ref::Mat;

namespace {

struct Mkn {
  std::int64_t m, k, n;
};
// m around the 120-row blocks and 1024-row tiles, k odd / 1 / past a 768 chunk /
// split (one tile, k >= 2000), n around the 16 .. 80 panel widths, two
// 512-column blocks and two 1024-column tiles; the 1100-row and k = 2101 shapes
// are large enough (4 Mflop) to run threaded.
const Mkn kShapes[] = {{1, 1, 1},    {5, 3, 2},      {37, 17, 8},   {121, 193, 16}, {250, 385, 17},
                       {26, 64, 81}, {13, 600, 33},  {49, 770, 72}, {1100, 64, 40},  {20, 1601, 24},
                       {40, 2101, 33}, {60, 300, 130}, {3, 1, 40}, {5, 24, 1030}};

struct Case {
  bool ta, tb;
  const char* name;
};
const Case kCases[] = {{false, false, "A B"}, {false, true, "dC B^T"}, {true, false, "A^T dC"}};

struct AlphaBeta {
  float alpha, beta;
};
const AlphaBeta kAlphaBeta[] = {{1.0f, 0.0f}, {1.0f, 1.0f}, {0.5f, -0.75f}};

}  // namespace

TEST_CASE("gemm bf16: the three training products against the double product of the rounded operands",
          "[gemm_bf16]") {
  Rng rng(41);
  const bool hw = bf16_supported();
  if (!hw) WARN("this CPU has no AVX512_BF16: only the portable bf16 product is checked");
  for (const Mkn& s : kShapes)
    for (const Case& c : kCases)
      for (const AlphaBeta& ab : kAlphaBeta) {
        const bool strided = (s.m + s.k + int(c.ta)) % 2 == 0;  // half the shapes on strided views
        const Tensor A = c.ta ? random(rng, s.k, s.m, strided) : random(rng, s.m, s.k, strided);
        const Tensor B = c.tb ? random(rng, s.n, s.k, !strided) : random(rng, s.k, s.n, !strided);
        const Tensor C0 = random(rng, s.m, s.n, false);
        Mat bound;
        const Mat want =
            ref::gemm(ref::rounded_bf16(A), c.ta, ref::rounded_bf16(B), c.tb, ref::to_mat(C0), ab.alpha, ab.beta, &bound);
        // k sums and the beta C term: (k + 2) roundings of at most u each.
        const double rel = double(s.k + 2) * std::ldexp(1.0, -24) * 1.001;
        std::vector<cpu::SimdLevel> levels = {cpu::SimdLevel::scalar};  // below AVX-512: the portable product
        if (hw) levels.push_back(cpu::SimdLevel::avx512);
        Tensor first;
        for (auto level : levels) {
          Simd simd(level);
          for (int threads : {1, 2}) {
            Threads t(threads);
            Tensor C = make(s.m, s.n, strided);
            if (ab.beta == 0.0f)
              cpu::fill(C, std::numeric_limits<float>::quiet_NaN());  // beta = 0 ignores C
            else
              C.copy_from_(C0);
            cpu::gemm(A, c.ta, B, c.tb, C, ab.alpha, ab.beta, Precision::bf16);
            const std::string what = std::string(c.name) + " m " + std::to_string(s.m) + " k " +
                                     std::to_string(s.k) + " n " + std::to_string(s.n) + " alpha " +
                                     std::to_string(ab.alpha) + " beta " + std::to_string(ab.beta) + " strided " +
                                     std::to_string(strided) + " " + cpu::simd_level_name(level) + " threads " +
                                     std::to_string(threads);
            require_close_bound(C, want, bound, rel, 1e-30, what);
            REQUIRE(pad_intact(C));
            // The same bits for any thread count, and the kernel's bits from the emulation.
            if (!first.defined())
              first = C.clone();
            else {
              INFO(what);
              REQUIRE(bitwise_equal(C, first));
            }
          }
        }
      }
}

TEST_CASE("gemm bf16: differs from fp32 by the operands' rounding only", "[gemm_bf16]") {
  // Guards against a bf16 path that silently runs fp32 (or rounds too much):
  // on values with more than 8 significant bits the two differ, by about the
  // bf16 rounding of the operands (2^-9 relative each).
  Rng rng(42);
  const Tensor A = random(rng, 64, 96, false), B = random(rng, 96, 40, false);
  Tensor c32 = Tensor::empty(64, 40), c16 = Tensor::empty(64, 40);
  cpu::gemm(A, false, B, false, c32);
  cpu::gemm(A, false, B, false, c16, 1.0f, 0.0f, Precision::bf16);
  Mat bound;
  ref::gemm(ref::to_mat(A), false, ref::to_mat(B), false, Mat(64, 40), 1.0, 0.0, &bound);
  double worst = 0, differ = 0;
  for (std::int64_t i = 0; i < 64; ++i)
    for (std::int64_t j = 0; j < 40; ++j) {
      worst = std::max(worst, std::fabs(double(c16.at(i, j)) - c32.at(i, j)) / bound(i, j));
      differ += c16.at(i, j) != c32.at(i, j);
    }
  CHECK(differ > 64 * 40 / 2);
  CHECK(worst < 2 * std::ldexp(1.0, -8));  // two operands each within 2^-9
}

TEST_CASE("gemm bf16: per-call packing of B and of a transposed A is pack_b_bf16's layout (AVX512_BF16 CPUs)",
          "[gemm_bf16]") {
  if (!bf16_supported()) {
    WARN("this CPU has no AVX512_BF16: the per-call packing is not run here");
    return;
  }
  Rng rng(43);
  for (const Mkn& s : {Mkn{0, 1, 1}, Mkn{0, 7, 17}, Mkn{0, 33, 72}, Mkn{0, 770, 100}, Mkn{0, 64, 530}}) {
    const Tensor B = random(rng, s.k, s.n, true);
    const Tensor Bt = random(rng, s.n, s.k, true);  // op(B) = Bt^T
    Tensor Bt_copy = Tensor::empty(s.k, s.n);
    for (std::int64_t kk = 0; kk < s.k; ++kk)
      for (std::int64_t j = 0; j < s.n; ++j) Bt_copy.at(kk, j) = Bt.at(j, kk);
    const std::int64_t words = cpu::detail::packed_bf16_words(s.k, s.n);
    std::vector<std::uint32_t> want(static_cast<std::size_t>(words)), got(static_cast<std::size_t>(words), 0xDEADBEEFu);
    cpu::detail::pack_b_bf16(B.data(), B.ld(), s.k, s.n, want.data());
    cpu::detail::pack_b_bf16_strided_avx512(B.data(), B.ld(), 1, s.k, s.n, got.data());
    CHECK(got == want);
    cpu::detail::pack_b_bf16(Bt_copy.data(), Bt_copy.ld(), s.k, s.n, want.data());
    std::fill(got.begin(), got.end(), 0xDEADBEEFu);
    cpu::detail::pack_b_bf16_strided_avx512(Bt.data(), 1, Bt.ld(), s.k, s.n, got.data());
    CHECK(got == want);
    // Rows of op(A) = Bt (its columns k as pairs) from the transposed storage: Bt_copy^T.
    const std::int64_t kp = (s.n + 1) / 2, ldw = kp + 3;
    std::vector<std::uint32_t> rows(std::size_t(s.k * ldw), 0u), expect(std::size_t(s.k * ldw), 0u);
    cpu::detail::bf16_pairs_strided_avx512(Bt.data(), 1, Bt.ld(), s.k, s.n, rows.data(), ldw);
    for (std::int64_t i = 0; i < s.k; ++i)
      for (std::int64_t p = 0; p < kp; ++p) {
        const std::uint32_t lo = cpu::bf16_bits(Bt.at(2 * p, i));
        const std::uint32_t hi = 2 * p + 1 < s.n ? cpu::bf16_bits(Bt.at(2 * p + 1, i)) : 0u;
        expect[std::size_t(i * ldw + p)] = lo | (hi << 16);
      }
    CHECK(rows == expect);
  }
}
