// Dense NN kernels (GEMM, elementwise, row softmax, batch norm, losses,
// DenseNet concat) against the double-precision references, on contiguous and
// strided (column-slice) tensors, at every SIMD level this CPU supports, and
// for 1 vs 2 threads (bitwise).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "src/backends/cpu/batchnorm.hpp"
#include "src/backends/cpu/dense_concat.hpp"
#include "src/backends/cpu/elementwise.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/loss.hpp"
#include "src/backends/cpu/row_softmax.hpp"
#include "reference/nn_reference.hpp"

using namespace gatcore;
using namespace gatcore::testutil;
using Catch::Matchers::Contains;
using ref::Mat;

namespace {

const Activation kActs[] = {Activation::identity, Activation::tanh, Activation::tanhshrink, Activation::leaky_relu,
                            Activation::relu};

std::string level_name(cpu::SimdLevel l) { return cpu::simd_level_name(l); }

struct Shape {
  std::int64_t r, c;
};
const Shape kShapes[] = {{1, 1}, {1, 37}, {17, 33}, {5, 1}, {300, 64}};

}  // namespace

// ==== GEMM ===============================================================================

TEST_CASE("gemm: transpose combinations, alpha/beta, strided views, odd sizes", "[gemm]") {
  Rng rng(11);
  struct Sz {
    std::int64_t m, k, n;
  };
  // {33, 4100, 17}: a long k with a small C (split into k chunks).
  // {130, 400, 40} and {250, 70, 8}: several k blocks, row blocks and partial
  // register tiles of the packed AVX-512 kernel (both its 32- and 16-wide
  // paths); {100, 500, 3}: its narrow transposed-A path with a partial vector;
  // {150, 300, 200} and {37, 45, 130}: n >= 128, where A row blocks are packed
  // too (16 x 16 register transposes with partial row panels, k tails of a
  // block that are not multiples of 16, a last B panel of 8 columns).
  const Sz sizes[] = {{1, 1, 1},      {1, 7, 1},       {17, 33, 5},    {5, 1, 9},    {64, 130, 70},
                      {129, 257, 33}, {33, 4100, 17}, {130, 400, 40}, {250, 70, 8}, {100, 500, 3},
                      {150, 300, 200}, {37, 45, 130}};
  const std::pair<float, float> ab[] = {{1.0f, 0.0f}, {0.5f, 2.0f}, {-1.25f, 1.0f}};
  for (auto level : simd_levels()) {
    Simd simd(level);
    for (const Sz& s : sizes)
      for (int t = 0; t < 4; ++t)
        for (int strided = 0; strided < 2; ++strided)
          for (auto [alpha, beta] : ab) {
            const bool ta = t & 1, tb = t & 2;
            Tensor A = ta ? random(rng, s.k, s.m, strided) : random(rng, s.m, s.k, strided);
            Tensor B = tb ? random(rng, s.n, s.k, !strided) : random(rng, s.k, s.n, !strided);
            Tensor C = random(rng, s.m, s.n, strided);
            if (beta == 0.0f) C.fill_(std::numeric_limits<float>::quiet_NaN());  // must be ignored
            Mat bound;
            const Mat want = ref::gemm(ref::to_mat(A), ta, ref::to_mat(B), tb, ref::to_mat(C), alpha, beta, &bound);
            cpu::gemm(A, ta, B, tb, C, alpha, beta);
            INFO("level " << level_name(level) << " m,k,n " << s.m << "," << s.k << "," << s.n << " ta " << ta
                          << " tb " << tb << " strided " << strided << " alpha " << alpha << " beta " << beta);
            require_close_bound(C, want, bound, 2e-6 * std::sqrt(double(s.k)) + 1e-6, 1e-7, "gemm");
            REQUIRE(pad_intact(C));
          }
  }
}

TEST_CASE("gemm: the Eigen build of each SIMD level is what it says", "[gemm]") {
  INFO("baseline build: " << cpu::detail::gemm_eigen_isa_baseline());  // SSE2 (more with GATCORE_NATIVE)
  CHECK(std::string(cpu::detail::gemm_eigen_isa_baseline()) != "none");
#if defined(__x86_64__) && defined(__GNUC__)
  CHECK(std::string(cpu::detail::gemm_eigen_isa_avx2()) == "AVX2+FMA");
  CHECK(std::string(cpu::detail::gemm_eigen_isa_avx512()) == "AVX512+FMA");
#endif
  // and a larger product per level
  Rng rng(12);
  Tensor A = random(rng, 300, 200, false), B = random(rng, 200, 150, true);
  Mat bound;
  const Mat want = ref::gemm(ref::to_mat(A), false, ref::to_mat(B), false, Mat(300, 150), 1.0, 0.0, &bound);
  for (auto level : simd_levels()) {
    Simd simd(level);
    Tensor C = Tensor::zeros(300, 150);
    cpu::gemm(A, false, B, false, C);
    require_close_bound(C, want, bound, 5e-5, 1e-7, "gemm " + level_name(level));
  }
}

TEST_CASE("gemm: empty inner dimension and alpha = 0 give beta C", "[gemm]") {
  Rng rng(13);
  Tensor A = Tensor::empty(3, 0), B = Tensor::empty(0, 4);
  Tensor C = random(rng, 3, 4, true);
  const Mat c0 = ref::to_mat(C);
  cpu::gemm(A, false, B, false, C, 1.0f, 0.5f);
  for (std::int64_t r = 0; r < 3; ++r)
    for (std::int64_t c = 0; c < 4; ++c) REQUIRE(C.at(r, c) == static_cast<float>(0.5 * c0(r, c)));
  C.fill_(std::numeric_limits<float>::quiet_NaN());
  cpu::gemm(A, false, B, false, C, 1.0f, 0.0f);
  for (float v : C.to_vector()) REQUIRE(v == 0.0f);
  Tensor A2 = random(rng, 3, 5, false), B2 = random(rng, 5, 4, false);
  C.fill_(std::numeric_limits<float>::quiet_NaN());
  cpu::gemm(A2, false, B2, false, C, 0.0f, 0.0f);
  for (float v : C.to_vector()) REQUIRE(v == 0.0f);
}

TEST_CASE("gemm: a DenseNet prefix slice times W into the next slot of the same buffer", "[gemm]") {
  Rng rng(14);
  Tensor buf = random(rng, 50, 20, false);
  Tensor prefix = buf.cols_slice(0, 12), slot = buf.cols_slice(12, 20);
  Tensor W = random(rng, 12, 8, false);
  Mat bound;
  const Mat want = ref::gemm(ref::to_mat(prefix), false, ref::to_mat(W), false, Mat(50, 8), 1.0, 0.0, &bound);
  const Mat prefix_before = ref::to_mat(prefix);
  cpu::gemm(prefix, false, W, false, slot);
  require_close_bound(slot, want, bound, 1e-5, 1e-7, "slot");
  require_close(prefix, prefix_before, 0, 0, "prefix unchanged");
}

TEST_CASE("gemm: a last panel of <= 16 columns gives bitwise the sums of a full panel", "[gemm]") {
  // The AVX-512 product runs the last panel of an n = 72 product (64 + 8)
  // with a narrower tile than a full 32-wide one; every column must still be
  // the same FMA chain. Reference: the same A times B widened to a multiple
  // of 32 columns (the extra ones random), whose panels are all full.
  // Both read modes of A (rows in place below n = 128, packed above), A
  // transposed, a bottom partial row tile (m = 130), alpha and beta. (The
  // Eigen builds of the lower levels make no such promise across widths.)
  Rng rng(19);
  if (cpu::detected_simd_level() != cpu::SimdLevel::avx512) {
    WARN("this CPU has no AVX-512: the packed AVX-512 product is not run here");
    return;
  }
  Simd simd(cpu::SimdLevel::avx512);
  for (std::int64_t n : {65, 72, 76, 80, 200, 204})
    for (int ta = 0; ta < 2; ++ta) {
      const std::int64_t m = 130, k = 300, wide = (n + 31) / 32 * 32;
      const Tensor A = ta ? random(rng, k, m, false) : random(rng, m, k, false);
      const Tensor Bw = random(rng, k, wide, false), Cw = random(rng, m, wide, false);
      const Tensor B = Bw.cols_slice(0, n).clone(), C = Cw.cols_slice(0, n).clone();
      cpu::gemm(A, ta, B, false, C, 0.5f, 2.0f);
      cpu::gemm(A, ta, Bw, false, Cw, 0.5f, 2.0f);
      INFO("n " << n << " (" << wide << ") ta " << ta);
      std::int64_t differ = 0;
      for (std::int64_t i = 0; i < m; ++i)
        for (std::int64_t j = 0; j < n; ++j) differ += C.at(i, j) != Cw.at(i, j);
      CHECK(differ == 0);
    }
}

TEST_CASE("gemm: 1 vs 2 threads give bitwise identical results", "[gemm][determinism]") {
  Rng rng(15);
  Tensor A = random(rng, 600, 300, true), B = random(rng, 300, 260, false);
  Tensor At = random(rng, 300, 600, false), Bt = random(rng, 260, 300, true);
  for (auto level : simd_levels()) {
    Simd simd(level);
    for (int t = 0; t < 4; ++t) {
      const bool ta = t & 1, tb = t & 2;
      Tensor C1 = Tensor::zeros(600, 260), C2 = Tensor::zeros(600, 260);
      {
        Threads th(1);
        cpu::gemm(ta ? At : A, ta, tb ? Bt : B, tb, C1);
      }
      {
        Threads th(2);
        cpu::gemm(ta ? At : A, ta, tb ? Bt : B, tb, C2);
      }
      INFO("level " << level_name(level) << " ta " << ta << " tb " << tb);
      REQUIRE(bitwise_equal(C1, C2));
    }
    // A weight-gradient shape: small C, long k (split-k partials).
    Tensor X = random(rng, 6000, 90, true), G = random(rng, 6000, 70, false);
    Tensor W1 = random(rng, 90, 70, false), W2 = W1.clone();
    {
      Threads th(1);
      cpu::gemm(X, true, G, false, W1, 1.0f, 1.0f);
    }
    {
      Threads th(2);
      cpu::gemm(X, true, G, false, W2, 1.0f, 1.0f);
    }
    REQUIRE(bitwise_equal(W1, W2));
  }
}

TEST_CASE("gemm: the tile plan gives 2 threads equal work on the models' shapes", "[gemm][determinism]") {
  // What a thread gets under the static schedule gemm_tiled uses (tasks in
  // order, split evenly): the larger share of the multiply-adds, in [0.5, 1].
  const auto larger_share = [](const cpu::detail::GemmTilePlan& p, std::int64_t m, std::int64_t n, std::int64_t k) {
    const std::int64_t tasks = p.tiles_m * p.tiles_n * p.splits;
    double work[2] = {0.0, 0.0};
    for (std::int64_t task = 0; task < tasks; ++task) {
      const std::int64_t t = task / p.splits, sp = task % p.splits;
      const std::int64_t i0 = (t / p.tiles_n) * p.tile_m, j0 = (t % p.tiles_n) * p.tile_n;
      const double mi = double(std::min(p.tile_m, m - i0)), nj = double(std::min(p.tile_n, n - j0));
      const double kk = double(std::min(p.kc, k - sp * p.kc));
      work[task < (tasks + 1) / 2 ? 0 : 1] += mi * nj * kk;
    }
    return std::max(work[0], work[1]) / (work[0] + work[1]);
  };
  struct Case {
    std::int64_t m, n, k, tile;
  };
  // NeuroSkinning's classifier weight gradient (1088 x 1024, k = 12 x 2048)
  // in bf16 (1024) and fp32 (512) tiles; a weight gradient that took 7 k
  // chunks; DenseGATs' shapes (8000 rows).
  const Case cases[] = {{1088, 1024, 24576, 1024}, {1088, 1024, 24576, 512}, {576, 512, 24576, 1024},
                        {8000, 504, 512, 512},     {504, 512, 8000, 512},     {24576, 1088, 1024, 1024}};
  for (const Case& c : cases) {
    const cpu::detail::GemmTilePlan p = cpu::detail::gemm_tile_plan(c.m, c.n, c.k, c.tile, c.tile);
    INFO("m " << c.m << " n " << c.n << " k " << c.k << " tile " << c.tile << ": tiles " << p.tiles_m << " x "
              << p.tiles_n << " of " << p.tile_m << " x " << p.tile_n << ", " << p.splits << " k chunks of "
              << p.kc);
    REQUIRE(p.tile_m <= c.tile);
    REQUIRE(p.tile_n <= c.tile);
    REQUIRE(p.tile_m % 16 == 0);
    REQUIRE(p.tiles_m * p.tile_m >= c.m);
    REQUIRE(p.tiles_n * p.tile_n >= c.n);
    REQUIRE(p.splits * p.kc >= c.k);
    REQUIRE(larger_share(p, c.m, c.n, c.k) < 0.53);
  }
  // The 1088-row case is two tiles of 544 rows (it was 1024 and 64).
  const cpu::detail::GemmTilePlan p = cpu::detail::gemm_tile_plan(1088, 1024, 24576, 1024, 1024);
  CHECK(p.tile_m == 544);
  CHECK(p.tiles_m == 2);
}

TEST_CASE("gemm: bad arguments throw naming the argument", "[gemm][errors]") {
  Tensor A = Tensor::zeros(3, 4), B = Tensor::zeros(5, 2), C = Tensor::zeros(3, 2);
  REQUIRE_THROWS_AS(cpu::gemm(A, false, B, false, C), InvalidArgument);
  REQUIRE_THROWS_WITH(cpu::gemm(A, false, B, false, C), Contains("gemm: B") && Contains("inner dimensions"));
  Tensor B2 = Tensor::zeros(4, 2), C2 = Tensor::zeros(3, 3);
  REQUIRE_THROWS_WITH(cpu::gemm(A, false, B2, false, C2), Contains("gemm: C: expected shape [3, 2], got [3, 3]"));
  REQUIRE_THROWS_WITH(cpu::gemm(A, true, B2, false, C), Contains("gemm: B"));
  REQUIRE_THROWS_WITH(cpu::gemm(Tensor(), false, B2, false, C), Contains("gemm: A"));
  REQUIRE_THROWS_WITH(cpu::gemm(Tensor::zeros(3, 4, DType::i32), false, B2, false, C),
                      Contains("gemm: A") && Contains("float32"));
  Tensor sq = Tensor::zeros(4, 4);
  REQUIRE_THROWS_WITH(cpu::gemm(sq, false, sq, false, sq), Contains("overlaps"));
}

// ==== activations ==========================================================================

TEST_CASE("activations: forward and backward vs reference, every SIMD level", "[elementwise][activation]") {
  Rng rng(21);
  const float slope = 0.1f;
  for (auto level : simd_levels())
    for (Activation f : kActs)
      for (const Shape& s : kShapes)
        for (int strided = 0; strided < 2; ++strided) {
          Simd simd(level);
          INFO("level " << level_name(level) << " act " << static_cast<int>(f) << " shape " << s.r << "x" << s.c
                        << " strided " << strided);
          Tensor x = random(rng, s.r, s.c, strided, -6.0f, 6.0f);
          // a few special values
          const float specials[] = {0.0f, -0.0f, 1e-5f, -3e-4f, 9.5f, -12.0f, 100.0f, 4e-4f};
          for (std::int64_t k = 0; k < std::min<std::int64_t>(8, x.numel()); ++k)
            x.at(k % s.r, (k * 7) % s.c) = specials[k];
          const Mat xm = ref::to_mat(x);
          Tensor y = make(s.r, s.c, !strided);
          cpu::activation_forward(f, x, y, slope);
          Mat want(s.r, s.c);
          for (std::size_t i = 0; i < want.v.size(); ++i) want.v[i] = ref::act(f, xm.v[i], slope);
          const bool approx = f == Activation::tanh || f == Activation::tanhshrink;
          require_close(y, want, approx ? 1e-6 : 0.0, approx ? 1e-6 : 1e-7, "forward");
          REQUIRE(pad_intact(y));

          Tensor dy = random(rng, s.r, s.c, !strided);
          Tensor dx = random(rng, s.r, s.c, strided);
          const Mat dym = ref::to_mat(dy), dx0 = ref::to_mat(dx);
          Mat gwant = dx0;
          for (std::size_t i = 0; i < gwant.v.size(); ++i) gwant.v[i] += ref::act_grad(f, xm.v[i], slope) * dym.v[i];
          const double gtol = approx ? 2e-6 : 1e-7;
          cpu::activation_backward(f, x, y, dy, dx, slope);
          require_close(dx, gwant, gtol, gtol, "backward (x, y)");
          REQUIRE(pad_intact(dx));
          if (f != Activation::tanhshrink) {
            // From y alone (tanh: 1 - y^2; ReLU family: the sign of y).
            Tensor dx2 = make(s.r, s.c, strided);
            dx2.copy_from_(Tensor::from(s.r, s.c, std::vector<float>(dx0.v.begin(), dx0.v.end())));
            cpu::activation_backward(f, Tensor(), y, dy, dx2, slope);
            require_close(dx2, gwant, gtol, gtol, "backward (y only)");
          }
          {
            // From x alone.
            Tensor dx3 = Tensor::from(s.r, s.c, std::vector<float>(dx0.v.begin(), dx0.v.end()));
            cpu::activation_backward(f, x, Tensor(), dy, dx3, slope);
            require_close(dx3, gwant, gtol, gtol, "backward (x only)");
          }
          // Written instead of accumulated (a fresh gradient buffer): the bits
          // of accumulating onto zeros, whatever d_x held (NaN here), from x
          // and y, x alone (tanh's other path) and y alone.
          for (int from = 0; from < 3; ++from) {
            if (from == 2 && f == Activation::tanhshrink) continue;
            const Tensor xa = from == 2 ? Tensor() : x, ya = from == 1 ? Tensor() : y;
            Tensor dz = make(s.r, s.c, strided), dw = make(s.r, s.c, strided);
            cpu::fill(dz, 0.0f);
            cpu::activation_backward(f, xa, ya, dy, dz, slope);
            cpu::fill(dw, std::numeric_limits<float>::quiet_NaN());
            cpu::activation_backward(f, xa, ya, dy, dw, slope, false);
            INFO("write mode, from " << (from == 0 ? "x and y" : from == 1 ? "x" : "y"));
            REQUIRE(bitwise_equal(dw, dz));
            REQUIRE(pad_intact(dw));
          }
          // d_x undefined: nothing to do, no error.
          cpu::activation_backward(f, x, y, dy, Tensor(), slope);
        }
}

TEST_CASE("tanh / tanhshrink: accuracy sweep over a long row, special values", "[elementwise][activation]") {
  const std::int64_t n = 80001;  // one long row: [-20, 20] in steps of 5e-4
  Tensor x = Tensor::empty(1, n);
  for (std::int64_t i = 0; i < n; ++i) x.at(0, i) = static_cast<float>(-20.0 + 40.0 * double(i) / double(n - 1));
  for (auto level : simd_levels()) {
    Simd simd(level);
    INFO("level " << level_name(level));
    Tensor t = Tensor::empty(1, n), s = Tensor::empty(1, n);
    cpu::activation_forward(Activation::tanh, x, t);
    cpu::activation_forward(Activation::tanhshrink, x, s);
    double worst_t = 0, worst_s = 0;
    for (std::int64_t i = 0; i < n; ++i) {
      const double xv = x.at(0, i), r = std::tanh(xv);
      worst_t = std::max(worst_t, std::fabs(t.at(0, i) - r));
      worst_s = std::max(worst_s, std::fabs(s.at(0, i) - (xv - r)) / std::max(1.0, std::fabs(xv)));
    }
    CHECK(worst_t < 5e-7);
    CHECK(worst_s < 1e-6);
    // Special values: NaN propagates, infinities saturate, the sign of zero is kept.
    Tensor sp = Tensor::from(1, 5, {std::numeric_limits<float>::quiet_NaN(), INFINITY, -INFINITY, -0.0f, 1e-30f});
    Tensor out = Tensor::empty(1, 5);
    cpu::activation_forward(Activation::tanh, sp, out);
    CHECK(std::isnan(out.at(0, 0)));
    CHECK(std::fabs(out.at(0, 1) - 1.0f) < 5e-7f);
    CHECK(std::fabs(out.at(0, 2) + 1.0f) < 5e-7f);
    CHECK((out.at(0, 3) == 0.0f && std::signbit(out.at(0, 3))));
    CHECK(out.at(0, 4) == 1e-30f);
    Tensor nanrelu = Tensor::empty(1, 5);
    cpu::activation_forward(Activation::relu, sp, nanrelu);
    CHECK(std::isnan(nanrelu.at(0, 0)));
  }
}

TEST_CASE("activations: in place and argument errors", "[elementwise][activation][errors]") {
  Rng rng(22);
  Tensor x = random(rng, 9, 13, true, -3, 3);
  const Mat xm = ref::to_mat(x);
  cpu::activation_forward(Activation::tanh, x, x);  // y aliases x
  Mat want(9, 13);
  for (std::size_t i = 0; i < want.v.size(); ++i) want.v[i] = std::tanh(xm.v[i]);
  require_close(x, want, 1e-6, 1e-6, "in place");

  Tensor a = Tensor::zeros(4, 5), b = Tensor::zeros(4, 6);
  REQUIRE_THROWS_WITH(cpu::activation_forward(Activation::relu, a, b),
                      Contains("activation_forward: y: expected shape [4, 5], got [4, 6]"));
  REQUIRE_THROWS_WITH(cpu::activation_backward(Activation::relu, a, Tensor(), a, b),
                      Contains("activation_backward: d_x: expected shape [4, 5]"));
  REQUIRE_THROWS_WITH(cpu::activation_backward(Activation::tanhshrink, Tensor(), a, a, a),
                      Contains("tanhshrink") && Contains("x"));
  REQUIRE_THROWS_WITH(cpu::activation_backward(Activation::tanh, Tensor(), Tensor(), a, a), Contains("undefined"));
  REQUIRE_THROWS_WITH(cpu::activation_backward(Activation::tanh, a, b, a, a), Contains("activation_backward: y"));
}

// ==== other elementwise kernels and reductions ===============================================

TEST_CASE("bias_activation_rows: bitwise add_row_bias then activation_forward on its rows, every SIMD level",
          "[elementwise][activation]") {
  // A dense layer's finish per row block (the deploy path's product sink):
  // rows [r0, r1) only, lin updated in place, y = f(lin); rows outside the
  // range untouched; strided tensors; no bias.
  Rng rng(33);
  for (auto level : simd_levels()) {
    Simd simd(level);
    for (const Shape& s : {Shape{1, 1}, Shape{17, 33}, Shape{300, 64}, Shape{130, 512}})
      for (Activation f : {Activation::identity, Activation::tanh, Activation::tanhshrink})
        for (int strided = 0; strided < 2; ++strided)
          for (int with_bias = 0; with_bias < 2; ++with_bias) {
            INFO("level " << level_name(level) << " shape " << s.r << "x" << s.c << " " << activation_name(f)
                          << " strided " << strided << " bias " << with_bias);
            const Tensor lin0 = random(rng, s.r, s.c, strided);
            const Tensor bias = with_bias ? random(rng, 1, s.c, !strided) : Tensor{};
            // The composition, over every row.
            const Tensor want_lin = lin0.clone();
            if (with_bias) cpu::add_row_bias(bias, want_lin);
            const Tensor want_y = make(s.r, s.c, strided);
            cpu::activation_forward(f, want_lin, want_y);
            // The rows in two ranges (a block boundary inside), as sinks hand them out.
            const Tensor lin = lin0.clone();
            const Tensor y = make(s.r, s.c, !strided);
            y.fill_(-7.0f);
            const std::int64_t mid = s.r / 3;
            cpu::bias_activation_rows(bias, f, lin, f == Activation::identity && strided ? Tensor{} : y, mid, s.r);
            std::int64_t touched = 0;
            for (std::int64_t r = 0; r < mid; ++r)  // not yet: untouched
              for (std::int64_t c = 0; c < s.c; ++c) touched += lin.at(r, c) != lin0.at(r, c) || y.at(r, c) != -7.0f;
            CHECK(touched == 0);
            cpu::bias_activation_rows(bias, f, lin, f == Activation::identity && strided ? Tensor{} : y, 0, mid);
            std::int64_t differ = 0;
            for (std::int64_t r = 0; r < s.r; ++r)
              for (std::int64_t c = 0; c < s.c; ++c) {
                differ += lin.at(r, c) != want_lin.at(r, c);
                if (f != Activation::identity || !strided) differ += y.at(r, c) != want_y.at(r, c);
                else differ += y.at(r, c) != -7.0f;  // identity without an output writes none
              }
            CHECK(differ == 0);
            REQUIRE(pad_intact(y));
          }
  }
  const Tensor lin = Tensor::zeros(4, 3), y = Tensor::zeros(4, 3);
  CHECK_THROWS_WITH(cpu::bias_activation_rows(Tensor{}, Activation::relu, lin, y, 0, 4), Contains("relu"));
  CHECK_THROWS_WITH(cpu::bias_activation_rows(Tensor{}, Activation::tanh, lin, Tensor{}, 0, 4),
                    Contains("needs an output"));
  CHECK_THROWS_WITH(cpu::bias_activation_rows(Tensor::zeros(1, 2), Activation::tanh, lin, y, 0, 4),
                    Contains("bias_activation_rows: bias"));
  CHECK_THROWS_WITH(cpu::bias_activation_rows(Tensor{}, Activation::tanh, lin, y, 2, 5), Contains("outside the 4 rows"));
  CHECK_THROWS_WITH(cpu::bias_activation_rows(Tensor{}, Activation::tanh, lin, Tensor::zeros(3, 3), 0, 3),
                    Contains("bias_activation_rows: y"));
}

TEST_CASE("axpby, axpy, mul, mul_accumulate, add_row_bias, fill", "[elementwise]") {
  Rng rng(31);
  for (const Shape& s : kShapes)
    for (int strided = 0; strided < 2; ++strided) {
      INFO("shape " << s.r << "x" << s.c << " strided " << strided);
      Tensor a = random(rng, s.r, s.c, strided), b = random(rng, s.r, s.c, !strided);
      const Mat am = ref::to_mat(a), bm = ref::to_mat(b);
      Mat w(s.r, s.c);

      Tensor y = make(s.r, s.c, strided);
      cpu::axpby(0.75f, a, -1.5f, b, y);
      for (std::size_t i = 0; i < w.v.size(); ++i) w.v[i] = 0.75 * am.v[i] - 1.5 * bm.v[i];
      require_close(y, w, 1e-6, 1e-6, "axpby");
      REQUIRE(pad_intact(y));
      Tensor a2 = a.clone();
      cpu::axpby(0.75f, a2, -1.5f, b, a2);  // y aliases a
      require_close(a2, w, 1e-6, 1e-6, "axpby in place");

      Tensor y2 = b.clone();
      cpu::axpy(2.5f, a, y2);
      for (std::size_t i = 0; i < w.v.size(); ++i) w.v[i] = bm.v[i] + 2.5 * am.v[i];
      require_close(y2, w, 1e-6, 1e-6, "axpy");

      Tensor y3 = make(s.r, s.c, !strided);
      cpu::mul(a, b, y3);
      for (std::size_t i = 0; i < w.v.size(); ++i) w.v[i] = am.v[i] * bm.v[i];
      require_close(y3, w, 1e-7, 1e-6, "mul");

      Tensor d = random(rng, s.r, s.c, strided);
      const Mat dm = ref::to_mat(d);
      cpu::mul_accumulate(a, b, d);
      for (std::size_t i = 0; i < w.v.size(); ++i) w.v[i] = dm.v[i] + am.v[i] * bm.v[i];
      require_close(d, w, 1e-6, 1e-6, "mul_accumulate");
      cpu::mul_accumulate(a, b, Tensor());  // undefined gradient: no-op

      Tensor bias = random(rng, 1, s.c, strided);
      Tensor y4 = a.clone();
      cpu::add_row_bias(bias, y4);
      for (std::int64_t r = 0; r < s.r; ++r)
        for (std::int64_t c = 0; c < s.c; ++c) w(r, c) = am(r, c) + bias.at(0, c);
      require_close(y4, w, 1e-6, 1e-6, "add_row_bias");

      Tensor y5 = make(s.r, s.c, true);
      cpu::fill(y5, 3.5f);
      for (std::int64_t r = 0; r < s.r; ++r)
        for (std::int64_t c = 0; c < s.c; ++c) REQUIRE(y5.at(r, c) == 3.5f);
      REQUIRE(pad_intact(y5));
    }
  Tensor a = Tensor::zeros(2, 3);
  REQUIRE_THROWS_WITH(cpu::axpby(1, a, 1, Tensor::zeros(3, 2), a), Contains("axpby: b: expected shape [2, 3], got [3, 2]"));
  REQUIRE_THROWS_WITH(cpu::axpy(1, a, Tensor::zeros(2, 2)), Contains("axpy: y"));
  REQUIRE_THROWS_WITH(cpu::mul(a, a, Tensor()), Contains("mul: y") && Contains("undefined"));
  REQUIRE_THROWS_WITH(cpu::add_row_bias(Tensor::zeros(2, 3), a), Contains("add_row_bias: bias: expected shape [1, 3]"));
  REQUIRE_THROWS_WITH(cpu::mul_accumulate(a, a, Tensor::zeros(2, 4)), Contains("mul_accumulate: d_a"));
}

TEST_CASE("column_sums_accumulate and sum_all vs double reference, incl. many rows", "[elementwise][reduction]") {
  Rng rng(32);
  const Shape shapes[] = {{1, 1}, {1, 37}, {17, 33}, {5, 1}, {100003, 7}, {3000, 130}};
  for (const Shape& s : shapes)
    for (int strided = 0; strided < 2; ++strided) {
      INFO("shape " << s.r << "x" << s.c << " strided " << strided);
      Tensor g = random(rng, s.r, s.c, strided, -1.0f, 3.0f);
      Tensor db = random(rng, 1, s.c, !strided);
      Mat want = ref::to_mat(db);
      double total = 0;
      for (std::int64_t r = 0; r < s.r; ++r)
        for (std::int64_t c = 0; c < s.c; ++c) {
          want(0, c) += g.at(r, c);
          total += g.at(r, c);
        }
      cpu::column_sums_accumulate(g, db);
      require_close(db, want, 1e-6, 1e-6, "column sums");
      REQUIRE(pad_intact(db));
      cpu::column_sums_accumulate(g, Tensor());  // undefined: no-op
      const double got = cpu::sum_all(g);
      REQUIRE(std::fabs(got - total) <= 1e-9 * std::max(1.0, std::fabs(total)));
    }
  REQUIRE(cpu::sum_all(Tensor::zeros(0, 5)) == 0.0);
  REQUIRE_THROWS_WITH(cpu::column_sums_accumulate(Tensor::zeros(4, 3), Tensor::zeros(1, 4)),
                      Contains("column_sums_accumulate: d_bias: expected shape [1, 3], got [1, 4]"));
}

// ==== row softmax ============================================================================

TEST_CASE("row softmax: masked forward / backward, every SIMD level", "[softmax]") {
  Rng rng(41);
  const Shape shapes[] = {{1, 1}, {1, 37}, {17, 33}, {5, 1}, {200, 53}, {3, 200}};
  for (auto level : simd_levels())
    for (const Shape& s : shapes)
      for (int masked = 0; masked < 2; ++masked)
        for (int strided = 0; strided < 2; ++strided) {
          Simd simd(level);
          INFO("level " << level_name(level) << " shape " << s.r << "x" << s.c << " masked " << masked << " strided "
                        << strided);
          Tensor x = random(rng, s.r, s.c, strided, -8.0f, 8.0f);
          if (s.r > 2) {
            for (std::int64_t c = 0; c < s.c; ++c) x.at(1, c) += 1000.0f;  // large logits: stable
            x.at(2, 0) = -INFINITY;                                         // a -inf logit: probability 0
          }
          Tensor mask;
          std::vector<double> mv(s.c, 1.0);
          if (masked) {
            mask = make(1, s.c, strided);
            for (std::int64_t c = 0; c < s.c; ++c) mask.at(0, c) = mv[c] = (c % 3 == 1) ? 0.0f : 1.0f;
          }
          Tensor y = make(s.r, s.c, !strided);
          cpu::row_softmax_forward(x, mask, y);
          const Mat want = ref::softmax(ref::to_mat(x), masked ? &mv : nullptr);
          require_close(y, want, 1e-7, 2e-6, "softmax forward");
          REQUIRE(pad_intact(y));

          Tensor dy = random(rng, s.r, s.c, strided), dx = random(rng, s.r, s.c, !strided);
          const Mat gw = plus(ref::to_mat(dx), ref::softmax_backward(ref::to_mat(y), ref::to_mat(dy)));
          cpu::row_softmax_backward(y, dy, dx);
          require_close(dx, gw, 1e-6, 1e-5, "softmax backward");
        }
}

TEST_CASE("row softmax: a fully masked row gives 0, not NaN", "[softmax]") {
  for (auto level : simd_levels()) {
    Simd simd(level);
    for (std::int64_t C : {1, 5, 16, 37}) {
      Tensor x = Tensor::full(3, C, 2.0f);
      Tensor mask = Tensor::zeros(1, C);
      Tensor y = Tensor::full(3, C, 7.0f);
      cpu::row_softmax_forward(x, mask, y);
      for (float v : y.to_vector()) REQUIRE(v == 0.0f);
      Tensor dx = Tensor::zeros(3, C);
      cpu::row_softmax_backward(y, Tensor::full(3, C, 1.0f), dx);
      for (float v : dx.to_vector()) REQUIRE(v == 0.0f);
      // every logit -inf: also all zeros
      Tensor xi = Tensor::full(2, C, -INFINITY);
      Tensor yi = Tensor::empty(2, C);
      cpu::row_softmax_forward(xi, Tensor(), yi);
      for (float v : yi.to_vector()) REQUIRE(v == 0.0f);
    }
  }
  REQUIRE_THROWS_WITH(cpu::row_softmax_forward(Tensor::zeros(2, 3), Tensor::zeros(1, 4), Tensor::zeros(2, 3)),
                      Contains("row_softmax_forward: mask: expected shape [1, 3], got [1, 4]"));
  REQUIRE_THROWS_WITH(cpu::row_softmax_backward(Tensor::zeros(2, 3), Tensor::zeros(2, 4), Tensor::zeros(2, 3)),
                      Contains("row_softmax_backward: d_y"));
}

// ==== batch norm ===============================================================================

namespace {
std::vector<double> row0(const Tensor& t) {
  std::vector<double> v(t.cols());
  for (std::int64_t c = 0; c < t.cols(); ++c) v[c] = t.at(0, c);
  return v;
}
Mat row_mat(const std::vector<double>& v) {
  Mat m(1, static_cast<std::int64_t>(v.size()));
  m.v = v;
  return m;
}
}  // namespace

TEST_CASE("batchnorm: train forward, running stats, train backward", "[batchnorm]") {
  Rng rng(51);
  const Shape shapes[] = {{2, 1}, {17, 33}, {1000, 64}, {3001, 5}};
  const float eps = 1e-5f, momentum = 0.1f;
  for (const Shape& s : shapes)
    for (int strided = 0; strided < 2; ++strided)
      for (float offset : {0.0f, 1000.0f}) {
        INFO("shape " << s.r << "x" << s.c << " strided " << strided << " offset " << offset);
        Tensor x = random(rng, s.r, s.c, strided, offset - 2.0f, offset + 2.0f);
        Tensor gamma = random(rng, 1, s.c, strided, 0.5f, 1.5f), beta = random(rng, 1, s.c, !strided);
        Tensor rm = random(rng, 1, s.c, strided), rv = random(rng, 1, s.c, strided, 0.5f, 2.0f);
        const Mat xm = ref::to_mat(x);
        const std::vector<double> g = row0(gamma), b = row0(beta), rm0 = row0(rm), rv0 = row0(rv);
        Tensor y = make(s.r, s.c, !strided), sm = make(1, s.c, strided), si = make(1, s.c, !strided);
        cpu::batchnorm_train_forward(x, gamma, beta, eps, momentum, y, sm, si, rm, rv);

        const ref::BnStats st = ref::column_stats(xm);
        require_close(y, ref::bn_apply(xm, st.mean, st.var, eps, g, b), 2e-5, 1e-5, "y");
        REQUIRE(pad_intact(y));
        std::vector<double> invstd(s.c), rm1(s.c), rv1(s.c);
        for (std::int64_t c = 0; c < s.c; ++c) {
          invstd[c] = 1.0 / std::sqrt(st.var[c] + eps);
          rm1[c] = (1 - momentum) * rm0[c] + momentum * st.mean[c];
          rv1[c] = (1 - momentum) * rv0[c] + momentum * st.var[c] * s.r / (s.r - 1.0);
        }
        require_close(sm, row_mat(st.mean), 1e-6, 1e-7, "save_mean");
        require_close(si, row_mat(invstd), 1e-7, 1e-6, "save_invstd");
        require_close(rm, row_mat(rm1), 1e-6, 1e-6, "running_mean");
        require_close(rv, row_mat(rv1), 1e-6, 1e-6, "running_var");

        Tensor dy = random(rng, s.r, s.c, strided);
        Tensor dx = random(rng, s.r, s.c, !strided), dg = random(rng, 1, s.c, strided), db = random(rng, 1, s.c, false);
        Mat dxw;
        std::vector<double> dgw, dbw;
        ref::bn_train_backward(xm, g, eps, ref::to_mat(dy), dxw, dgw, dbw);
        const Mat dx_want = plus(ref::to_mat(dx), dxw), dg_want = plus(ref::to_mat(dg), row_mat(dgw)),
                  db_want = plus(ref::to_mat(db), row_mat(dbw));
        cpu::batchnorm_train_backward(x, gamma, sm, si, dy, dx, dg, db);
        const double tol = offset == 0.0f ? 1e-5 : 2e-4;  // saved float mean of offset data
        require_close(dx, dx_want, tol, 1e-4, "d_x");
        require_close(dg, dg_want, tol * std::sqrt(double(s.r)), 1e-4, "d_gamma");
        require_close(db, db_want, 1e-5, 1e-5, "d_beta");
        // Only some gradients wanted.
        Tensor db2 = Tensor::zeros(1, s.c);
        cpu::batchnorm_train_backward(x, gamma, sm, si, dy, Tensor(), Tensor(), db2);
        require_close(db2, row_mat(dbw), 1e-5, 1e-5, "d_beta alone");
        // d_x written instead of accumulated: the bits of accumulating onto
        // zeros, whatever it held (NaN here).
        Tensor dz = make(s.r, s.c, strided), dw = make(s.r, s.c, strided);
        cpu::fill(dz, 0.0f);
        cpu::batchnorm_train_backward(x, gamma, sm, si, dy, dz, Tensor(), Tensor());
        cpu::fill(dw, std::numeric_limits<float>::quiet_NaN());
        cpu::batchnorm_train_backward(x, gamma, sm, si, dy, dw, Tensor(), Tensor(), {}, false);
        REQUIRE(bitwise_equal(dw, dz));
        REQUIRE(pad_intact(dw));
      }
}

TEST_CASE("batchnorm: the reference backward matches finite differences", "[batchnorm][reference]") {
  Rng rng(52);
  Mat x(6, 3), dy(6, 3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (auto& v : x.v) v = u(rng);
  for (auto& v : dy.v) v = u(rng);
  std::vector<double> g = {0.7, 1.3, -0.4}, b = {0.1, -0.2, 0.3};
  const double eps = 1e-5;
  auto loss = [&](const Mat& xx, const std::vector<double>& gg, const std::vector<double>& bb) {
    const ref::BnStats st = ref::column_stats(xx);
    const Mat y = ref::bn_apply(xx, st.mean, st.var, eps, gg, bb);
    double L = 0;
    for (std::size_t i = 0; i < y.v.size(); ++i) L += y.v[i] * dy.v[i];
    return L;
  };
  Mat dx;
  std::vector<double> dg, db;
  ref::bn_train_backward(x, g, eps, dy, dx, dg, db);
  const double h = 1e-6;
  for (std::size_t i = 0; i < x.v.size(); ++i) {
    Mat xp = x, xm = x;
    xp.v[i] += h;
    xm.v[i] -= h;
    REQUIRE(std::fabs((loss(xp, g, b) - loss(xm, g, b)) / (2 * h) - dx.v[i]) < 1e-6);
  }
  for (std::size_t c = 0; c < 3; ++c) {
    auto gp = g, gm = g, bp = b, bm = b;
    gp[c] += h, gm[c] -= h, bp[c] += h, bm[c] -= h;
    REQUIRE(std::fabs((loss(x, gp, b) - loss(x, gm, b)) / (2 * h) - dg[c]) < 1e-6);
    REQUIRE(std::fabs((loss(x, g, bp) - loss(x, g, bm)) / (2 * h) - db[c]) < 1e-6);
  }
}

TEST_CASE("batchnorm_affine_forward with batchnorm_eval_scale equals the eval forward bitwise", "[batchnorm]") {
  // The deploy path (models/deploy.hpp) prepares the scale once and must
  // reproduce batchnorm_eval_forward exactly (gat deform's numbers).
  Rng rng(54);
  const float eps = 1e-5f;
  for (const Shape& s : kShapes)
    for (int strided = 0; strided < 2; ++strided) {
      INFO("shape " << s.r << "x" << s.c << " strided " << strided);
      Tensor x = random(rng, s.r, s.c, strided, -3.0f, 3.0f);
      Tensor gamma = random(rng, 1, s.c, false, 0.5f, 1.5f), beta = random(rng, 1, s.c, false);
      Tensor rm = random(rng, 1, s.c, false), rv = random(rng, 1, s.c, false, 0.2f, 2.0f);
      Tensor ref = make(s.r, s.c, false), got = make(s.r, s.c, strided);
      cpu::batchnorm_eval_forward(x, gamma, beta, rm, rv, eps, ref);
      Tensor scale = Tensor::empty(1, s.c);
      cpu::batchnorm_eval_scale(gamma, rv, eps, scale);
      cpu::batchnorm_affine_forward(x, rm, scale, beta, got);
      for (std::int64_t r = 0; r < s.r; ++r)
        for (std::int64_t c = 0; c < s.c; ++c) REQUIRE(got.at(r, c) == ref.at(r, c));
    }
  Tensor bad = Tensor::full(1, 4, -1.0f), scale = Tensor::empty(1, 4);
  REQUIRE_THROWS_WITH(cpu::batchnorm_eval_scale(Tensor(), bad, 1e-5f, scale), Catch::Contains("running_var + eps"));
}

TEST_CASE("batchnorm: eval forward / backward, no affine", "[batchnorm]") {
  Rng rng(53);
  const float eps = 1e-3f;
  for (const Shape& s : kShapes)
    for (int strided = 0; strided < 2; ++strided) {
      INFO("shape " << s.r << "x" << s.c << " strided " << strided);
      Tensor x = random(rng, s.r, s.c, strided, -3.0f, 3.0f);
      Tensor gamma = random(rng, 1, s.c, strided, 0.5f, 1.5f), beta = random(rng, 1, s.c, false);
      Tensor rm = random(rng, 1, s.c, strided), rv = random(rng, 1, s.c, !strided, 0.2f, 2.0f);
      const Mat xm = ref::to_mat(x);
      const std::vector<double> g = row0(gamma), b = row0(beta), m = row0(rm), v = row0(rv);
      Tensor y = make(s.r, s.c, !strided);
      cpu::batchnorm_eval_forward(x, gamma, beta, rm, rv, eps, y);
      require_close(y, ref::bn_apply(xm, m, v, eps, g, b), 1e-5, 1e-5, "eval y");
      // no affine transform
      cpu::batchnorm_eval_forward(x, Tensor(), Tensor(), rm, rv, eps, y);
      require_close(y, ref::bn_apply(xm, m, v, eps, std::vector<double>(s.c, 1.0), std::vector<double>(s.c, 0.0)),
                    1e-5, 1e-5, "eval y, no affine");

      Tensor dy = random(rng, s.r, s.c, !strided);
      Tensor dx = random(rng, s.r, s.c, strided), dg = random(rng, 1, s.c, false), db = random(rng, 1, s.c, true);
      Mat dxw = ref::to_mat(dx), dgw = ref::to_mat(dg), dbw = ref::to_mat(db);
      for (std::int64_t r = 0; r < s.r; ++r)
        for (std::int64_t c = 0; c < s.c; ++c) {
          const double is = 1.0 / std::sqrt(v[c] + eps), d = dy.at(r, c);
          dxw(r, c) += d * g[c] * is;
          dgw(0, c) += d * (xm(r, c) - m[c]) * is;
          dbw(0, c) += d;
        }
      cpu::batchnorm_eval_backward(x, gamma, rm, rv, eps, dy, dx, dg, db);
      require_close(dx, dxw, 1e-5, 1e-5, "eval d_x");
      require_close(dg, dgw, 1e-5, 1e-5, "eval d_gamma");
      require_close(db, dbw, 1e-5, 1e-5, "eval d_beta");
    }
  // train forward without affine parameters and without saving anything
  Tensor x = random(rng, 40, 6, true);
  Tensor y = Tensor::empty(40, 6);
  cpu::batchnorm_train_forward(x, Tensor(), Tensor(), 1e-5f, 0.1f, y, Tensor(), Tensor(), Tensor(), Tensor());
  const Mat xm = ref::to_mat(x);
  const ref::BnStats st = ref::column_stats(xm);
  require_close(y, ref::bn_apply(xm, st.mean, st.var, 1e-5, std::vector<double>(6, 1.0), std::vector<double>(6, 0.0)),
                1e-5, 1e-5, "train y, no affine");
}

TEST_CASE("batchnorm: bad arguments throw naming the argument", "[batchnorm][errors]") {
  Tensor x = Tensor::zeros(10, 64), y = Tensor::zeros(10, 64), p = Tensor::zeros(1, 64), bad = Tensor::zeros(1, 32);
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_forward(x, bad, p, 1e-5f, 0.1f, y, p, p, p, p),
                      Contains("batchnorm_train_forward: gamma: expected shape [1, 64], got [1, 32]"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_forward(x, p, p, 1e-5f, 0.1f, Tensor::zeros(10, 63), p, p, p, p),
                      Contains("batchnorm_train_forward: y"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_forward(x, p, p, 1e-5f, 0.1f, y, p, p, bad, p),
                      Contains("batchnorm_train_forward: running_mean"));
  Tensor x1 = Tensor::zeros(1, 64), y1 = Tensor::zeros(1, 64);
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_forward(x1, p, p, 1e-5f, 0.1f, y1, p, p, p, p),
                      Contains("batchnorm_train_forward: x") && Contains("more than 1 row"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_forward(x, p, p, 1e-5f, 1.5f, y, p, p, p, p), Contains("momentum"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_eval_forward(x, p, p, p, Tensor::full(1, 64, -1.0f), 1e-5f, y),
                      Contains("batchnorm_eval_forward: running_var"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_train_backward(x, p, bad, p, y, y, p, p),
                      Contains("batchnorm_train_backward: save_mean: expected shape [1, 64], got [1, 32]"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_eval_backward(x, p, p, p, 1e-5f, y, y, bad, p),
                      Contains("batchnorm_eval_backward: d_gamma"));
}

TEST_CASE("batchnorm_act: the fused kernels give batchnorm then the activation's values, every SIMD level",
          "[batchnorm]") {
  Rng rng(57);
  const Shape shapes[] = {{2, 1}, {17, 33}, {600, 40}};
  const float eps = 1e-5f, momentum = 0.1f, slope = 0.1f;
  for (auto level : simd_levels())
    for (const Shape& s : shapes)
      for (Activation f : {Activation::identity, Activation::relu, Activation::leaky_relu})
        for (int strided = 0; strided < 2; ++strided) {
          INFO(level_name(level) << " shape " << s.r << "x" << s.c << " " << activation_name(f) << " strided "
                                 << strided);
          Simd simd(level);
          Tensor x = random(rng, s.r, s.c, strided, -2.0f, 3.0f), dy = random(rng, s.r, s.c, !strided);
          Tensor gamma = random(rng, 1, s.c, false, -1.5f, 1.5f), beta = random(rng, 1, s.c, false);
          // Unfused: batchnorm_train_forward into u, the activation into y.
          Tensor u = make(s.r, s.c, false), y_want = make(s.r, s.c, strided);
          Tensor sm0 = make(1, s.c, false), si0 = make(1, s.c, false);
          Tensor rm0 = random(rng, 1, s.c, false), rv0 = random(rng, 1, s.c, false, 0.5f, 2.0f);
          Tensor rm1 = rm0.clone(), rv1 = rv0.clone();
          cpu::batchnorm_train_forward(x, gamma, beta, eps, momentum, u, sm0, si0, rm0, rv0);
          cpu::activation_forward(f, u, y_want, slope);
          // Fused.
          Tensor y = make(s.r, s.c, !strided), sm = make(1, s.c, false), si = make(1, s.c, false);
          Tensor aff = make(2, s.c, strided);
          cpu::batchnorm_act_train_forward(x, gamma, beta, eps, momentum, f, slope, y, sm, si, aff, rm1, rv1);
          require_close(y, ref::to_mat(y_want), 1e-6, 1e-6, "y");
          REQUIRE(bitwise_equal(sm, sm0));
          REQUIRE(bitwise_equal(si, si0));
          REQUIRE(bitwise_equal(rm1, rm0));
          REQUIRE(bitwise_equal(rv1, rv0));
          REQUIRE(pad_intact(y));
          // The recomputation is the forward's values bit for bit.
          Tensor y2 = make(s.r, s.c, strided);
          cpu::batchnorm_act_apply(x, beta, f, slope, sm, aff, y2);
          REQUIRE(bitwise_equal(y2, y));
          // Backward: the activation's, then batchnorm's, accumulated onto existing values.
          Tensor du = Tensor::zeros(s.r, s.c);
          cpu::activation_backward(f, u, Tensor(), dy, du, slope);
          Tensor dx_want = random(rng, s.r, s.c, false), dg_want = random(rng, 1, s.c, false),
                 db_want = random(rng, 1, s.c, false);
          Tensor dx = make(s.r, s.c, strided), dg = dg_want.clone(), db = db_want.clone();
          dx.copy_from_(dx_want);
          cpu::batchnorm_train_backward(x, gamma, sm0, si0, du, dx_want, dg_want, db_want);
          cpu::batchnorm_act_train_backward(x, gamma, beta, f, slope, sm, si, aff, dy, dx, dg, db);
          require_close(dx, ref::to_mat(dx_want), 1e-6, 1e-6, "d_x");
          require_close(dg, ref::to_mat(dg_want), 1e-6, 1e-6, "d_gamma");
          require_close(db, ref::to_mat(db_want), 1e-6, 1e-6, "d_beta");
          REQUIRE(pad_intact(dx));
          // Only some gradients wanted.
          Tensor db2 = Tensor::zeros(1, s.c), db2_want = Tensor::zeros(1, s.c);
          cpu::batchnorm_train_backward(x, gamma, sm0, si0, du, Tensor(), Tensor(), db2_want);
          cpu::batchnorm_act_train_backward(x, gamma, beta, f, slope, sm, si, aff, dy, Tensor(), Tensor(), db2);
          require_close(db2, ref::to_mat(db2_want), 1e-6, 1e-6, "d_beta alone");
          // d_x written instead of accumulated: the bits of accumulating onto zeros.
          Tensor dz = make(s.r, s.c, strided), dw = make(s.r, s.c, strided);
          cpu::fill(dz, 0.0f);
          cpu::batchnorm_act_train_backward(x, gamma, beta, f, slope, sm, si, aff, dy, dz, Tensor(), Tensor());
          cpu::fill(dw, std::numeric_limits<float>::quiet_NaN());
          cpu::batchnorm_act_train_backward(x, gamma, beta, f, slope, sm, si, aff, dy, dw, Tensor(), Tensor(), {},
                                            false);
          REQUIRE(bitwise_equal(dw, dz));
          REQUIRE(pad_intact(dw));
        }
}

TEST_CASE("batchnorm_act: an activation it does not fuse and bad shapes throw naming them", "[batchnorm][errors]") {
  Tensor x = Tensor::zeros(10, 8), y = Tensor::zeros(10, 8), p = Tensor::zeros(1, 8), a = Tensor::zeros(2, 8);
  REQUIRE_THROWS_WITH(
      cpu::batchnorm_act_train_forward(x, p, p, 1e-5f, 0.1f, Activation::tanh, 0.f, y, p, p, a, p, p),
      Contains("batchnorm_act_train_forward: activation 'tanh' is not fused"));
  REQUIRE_THROWS_WITH(
      cpu::batchnorm_act_train_forward(x, p, p, 1e-5f, 0.1f, Activation::relu, 0.f, y, p, p, p, p, p),
      Contains("batchnorm_act_train_forward: save_affine: expected shape [2, 8], got [1, 8]"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_act_apply(x, p, Activation::relu, 0.f, p, a, Tensor::zeros(10, 7)),
                      Contains("batchnorm_act_apply: y"));
  REQUIRE_THROWS_WITH(cpu::batchnorm_act_train_backward(x, p, p, Activation::leaky_relu, 0.1f, p, p, a,
                                                        Tensor::zeros(9, 8), y, p, p),
                      Contains("batchnorm_act_train_backward: d_y"));
}

// ==== losses ==================================================================================

TEST_CASE("mse: value and gradient", "[loss]") {
  Rng rng(61);
  for (const Shape& s : {Shape{1, 1}, Shape{17, 33}, Shape{20000, 7}})
    for (int strided = 0; strided < 2; ++strided) {
      Tensor p = random(rng, s.r, s.c, strided), t = random(rng, s.r, s.c, !strided);
      const Mat pm = ref::to_mat(p), tm = ref::to_mat(t);
      const double want = ref::mse(pm, tm);
      REQUIRE(std::fabs(cpu::mse_forward(p, t) - want) <= 1e-12 * want + 1e-15);
      Tensor d = random(rng, s.r, s.c, strided);
      Mat dw = ref::to_mat(d);
      const double n = double(s.r * s.c);
      for (std::size_t i = 0; i < dw.v.size(); ++i) dw.v[i] += 0.5 * 2.0 * (pm.v[i] - tm.v[i]) / n;
      cpu::mse_backward(p, t, 0.5f, d);
      require_close(d, dw, 1e-7, 1e-5, "mse grad");
      cpu::mse_backward(p, t, 0.5f, Tensor());
    }
  REQUIRE_THROWS_WITH(cpu::mse_forward(Tensor::zeros(2, 3), Tensor::zeros(3, 2)),
                      Contains("mse_forward: target: expected shape [2, 3], got [3, 2]"));
  REQUIRE_THROWS_WITH(cpu::mse_backward(Tensor::zeros(2, 3), Tensor::zeros(2, 3), 1.0f, Tensor::zeros(2, 2)),
                      Contains("mse_backward: d_pred"));
  REQUIRE_THROWS_WITH(cpu::mse_forward(Tensor::zeros(0, 3), Tensor::zeros(0, 3)), Contains("mse_forward: pred"));
}

TEST_CASE("kl divergence: zero targets and zero predictions stay finite", "[loss]") {
  Rng rng(62);
  const float eps = 1e-8f;
  for (const Shape& s : {Shape{1, 1}, Shape{17, 33}, Shape{5000, 9}})
    for (int strided = 0; strided < 2; ++strided) {
      INFO("shape " << s.r << "x" << s.c << " strided " << strided);
      Tensor p = random(rng, s.r, s.c, strided, 0.0f, 1.0f), t = random(rng, s.r, s.c, !strided, 0.0f, 1.0f);
      // zeros: target only, prediction only (under a positive target), both
      for (std::int64_t r = 0; r < s.r; ++r) {
        t.at(r, (r * 3) % s.c) = 0.0f;
        p.at(r, (r * 5 + 1) % s.c) = 0.0f;
        if (r % 4 == 0) p.at(r, (r * 3) % s.c) = 0.0f;
      }
      const Mat pm = ref::to_mat(p), tm = ref::to_mat(t);
      const double want = ref::kl(pm, tm, eps);
      const double got = cpu::kl_div_forward(p, t, eps);
      REQUIRE(std::isfinite(got));
      REQUIRE(std::fabs(got - want) <= 1e-9 * std::fabs(want) + 1e-12);
      Tensor d = random(rng, s.r, s.c, strided);
      Mat dw = ref::to_mat(d);
      for (std::size_t i = 0; i < dw.v.size(); ++i) dw.v[i] += 2.0 * (-tm.v[i] / std::max(pm.v[i], double(eps))) / s.r;
      cpu::kl_div_backward(p, t, eps, 2.0f, d);
      require_close(d, dw, 1e-6, 1e-6, "kl grad");
      for (float v : d.to_vector()) REQUIRE(std::isfinite(v));
    }
  // Identical distributions: 0.
  Tensor q = Tensor::from(2, 3, {0.2f, 0.3f, 0.5f, 0.0f, 1.0f, 0.0f});
  REQUIRE(std::fabs(cpu::kl_div_forward(q, q, 1e-8f)) < 1e-12);
  REQUIRE_THROWS_WITH(cpu::kl_div_forward(q, Tensor::from(2, 3, {0.2f, -0.3f, 0.5f, 0, 1, 0}), 1e-8f),
                      Contains("kl_div_forward: target") && Contains("row 0, column 1"));
  REQUIRE_THROWS_WITH(cpu::kl_div_forward(q, q, 0.0f), Contains("kl_div_forward: eps"));
  REQUIRE_THROWS_WITH(cpu::kl_div_backward(q, Tensor::zeros(3, 2), 1e-8f, 1.0f, q), Contains("kl_div_backward: target"));
}

// ==== DenseNet concat =============================================================================

TEST_CASE("dense concat: layout, slot and prefix views, copy kernels", "[dense]") {
  Rng rng(71);
  const cpu::DenseLayout L = cpu::dense_layout({3, 0, 5, 2});
  REQUIRE(L.offsets == std::vector<std::int64_t>{0, 3, 3, 8, 10});
  REQUIRE(L.width() == 10);
  REQUIRE(L.slots() == 4);
  Tensor buf = Tensor::zeros(7, 10);
  Tensor s2 = cpu::dense_slot(buf, L, 2);
  REQUIRE(s2.storage() == buf.storage());
  REQUIRE((s2.rows() == 7 && s2.cols() == 5 && s2.ld() == 10 && s2.offset() == 3));
  REQUIRE(cpu::dense_slot(buf, L, 1).cols() == 0);
  Tensor pre = cpu::dense_prefix(buf, L, 3);
  REQUIRE((pre.cols() == 8 && pre.offset() == 0 && pre.ld() == 10));
  REQUIRE(cpu::dense_prefix(buf, L, 0).cols() == 0);
  REQUIRE(cpu::dense_prefix(buf, L, 4).cols() == 10);
  REQUIRE_THROWS_WITH(cpu::dense_slot(buf, L, 4), Contains("dense_slot") && Contains("slot 4"));
  REQUIRE_THROWS_WITH(cpu::dense_prefix(buf, L, 5), Contains("dense_prefix") && Contains("slot 5"));
  REQUIRE_THROWS_WITH(cpu::dense_slot(Tensor::zeros(7, 9), L, 0), Contains("dense_slot: buffer: expected 10 columns"));
  REQUIRE_THROWS_WITH(cpu::dense_layout({2, -1}), Contains("widths[1]"));

  // features into slot 0 (from a strided source), gradient back out.
  Tensor feat = random(rng, 7, 3, true);
  cpu::concat_copy_forward(feat, buf, 0);
  require_close(cpu::dense_slot(buf, L, 0), ref::to_mat(feat), 0, 0, "copy forward");
  for (std::int64_t r = 0; r < 7; ++r)
    for (std::int64_t c = 3; c < 10; ++c) REQUIRE(buf.at(r, c) == 0.0f);
  cpu::concat_copy_forward(cpu::dense_slot(buf, L, 0), buf, 0);  // already in place: no-op
  require_close(cpu::dense_slot(buf, L, 0), ref::to_mat(feat), 0, 0, "in place");
  Tensor gbuf = random(rng, 7, 10, false);
  Tensor dfeat = random(rng, 7, 3, true);
  const Mat want = plus(ref::to_mat(dfeat), ref::to_mat(gbuf.cols_slice(3, 6)));
  cpu::concat_copy_backward(gbuf, 3, dfeat);
  require_close(dfeat, want, 0, 1e-7, "copy backward");
  REQUIRE(pad_intact(dfeat));
  cpu::concat_copy_backward(gbuf, 3, Tensor());
  REQUIRE_THROWS_WITH(cpu::concat_copy_forward(feat, buf, 8), Contains("concat_copy_forward: dst"));
  REQUIRE_THROWS_WITH(cpu::concat_copy_backward(gbuf, 8, dfeat), Contains("concat_copy_backward: d_src"));

  // general concat
  Tensor a = random(rng, 4, 2, true), b = random(rng, 4, 0, false), c = random(rng, 4, 5, false);
  Tensor out = make(4, 7, true);
  cpu::concat_columns({a, b, c}, out);
  require_close(out.cols_slice(0, 2), ref::to_mat(a), 0, 0, "part a");
  require_close(out.cols_slice(2, 7), ref::to_mat(c), 0, 0, "part c");
  REQUIRE(pad_intact(out));
  REQUIRE_THROWS_WITH(cpu::concat_columns({a, Tensor::zeros(3, 5)}, out), Contains("concat_columns: parts[1]"));
  REQUIRE_THROWS_WITH(cpu::concat_columns({a, a}, out), Contains("concat_columns: out: expected 4 columns"));
}

// ==== determinism: 1 vs 2 threads ==================================================================

TEST_CASE("elementwise, softmax, batch norm, losses: 1 vs 2 threads bitwise", "[determinism]") {
  Rng rng(81);
  const std::int64_t n = 3001, C = 67;
  Tensor x = random(rng, n, C, true, -3, 3), x2 = random(rng, n, C, false, -3, 3);
  Tensor g = random(rng, n, C, false), mask = Tensor::full(1, C, 1.0f);
  mask.at(0, 5) = 0.0f;
  Tensor gamma = random(rng, 1, C, false, 0.5f, 1.5f), beta = random(rng, 1, C, false);
  Tensor prob = random(rng, n, C, true, 0, 1), targ = random(rng, n, C, false, 0, 1);
  for (auto level : simd_levels()) {
    Simd simd(level);
    struct Out {
      std::vector<Tensor> t;
      std::vector<double> d;
    };
    auto run = [&](int threads) {
      Threads th(threads);
      Out o;
      auto add = [&](Tensor t) { o.t.push_back(t); };
      for (Activation f : kActs) {
        Tensor y = Tensor::empty(n, C), dx = g.clone();
        cpu::activation_forward(f, x, y, 0.1f);
        cpu::activation_backward(f, x, y, g, dx, 0.1f);
        Tensor dx2 = g.clone();
        cpu::activation_backward(f, x, Tensor(), g, dx2, 0.1f);
        add(y), add(dx), add(dx2);
      }
      Tensor y = Tensor::empty(n, C);
      cpu::axpby(0.3f, x, 0.7f, x2, y);
      add(y);
      Tensor bsum = Tensor::zeros(1, C);
      cpu::column_sums_accumulate(x, bsum);
      add(bsum);
      o.d.push_back(cpu::sum_all(x));
      Tensor sm = Tensor::empty(n, C), dsm = Tensor::zeros(n, C);
      cpu::row_softmax_forward(x, mask, sm);
      cpu::row_softmax_backward(sm, g, dsm);
      add(sm), add(dsm);
      Tensor by = Tensor::empty(n, C), smean = Tensor::empty(1, C), sinv = Tensor::empty(1, C);
      Tensor rm = Tensor::zeros(1, C), rv = Tensor::full(1, C, 1.0f);
      cpu::batchnorm_train_forward(x, gamma, beta, 1e-5f, 0.1f, by, smean, sinv, rm, rv);
      Tensor bdx = Tensor::zeros(n, C), bdg = Tensor::zeros(1, C), bdb = Tensor::zeros(1, C);
      cpu::batchnorm_train_backward(x, gamma, smean, sinv, g, bdx, bdg, bdb);
      add(by), add(smean), add(sinv), add(rm), add(rv), add(bdx), add(bdg), add(bdb);
      o.d.push_back(cpu::mse_forward(x, x2));
      o.d.push_back(cpu::kl_div_forward(prob, targ, 1e-8f));
      Tensor dk = Tensor::zeros(n, C);
      cpu::kl_div_backward(prob, targ, 1e-8f, 1.0f, dk);
      add(dk);
      return o;
    };
    const Out a = run(1), b = run(2);
    INFO("level " << level_name(level));
    REQUIRE(a.t.size() == b.t.size());
    for (std::size_t i = 0; i < a.t.size(); ++i) {
      INFO("output " << i);
      REQUIRE(bitwise_equal(a.t[i], b.t[i]));
    }
    for (std::size_t i = 0; i < a.d.size(); ++i) REQUIRE(a.d[i] == b.d[i]);
  }
}
