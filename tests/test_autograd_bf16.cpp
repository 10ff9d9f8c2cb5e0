// Training products in bf16 (precision.hpp's ProductPrecisionScope): linear
// and linear_segment_bias forward and both gradients against their fp32
// values, within the bound of the operands' rounding; the precision recorded
// at forward time and used by backward; fp32 where the backend has no bf16
// products (GATCORE_SIMD below AVX-512, a CPU without AVX512_BF16) and for
// products over fewer than 16 terms; 1 vs 2 threads bitwise; the fused
// batch_norm_act_linear's Linear the same way.
#include <catch2/catch.hpp>

#include <cmath>

#include "gatcore/models/train.hpp"
#include "gatcore/ops.hpp"
#include "gatcore/precision.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"
#include "reference/nn_reference.hpp"

using namespace gatcore;
using gradcheck::random_tensor;

namespace {

// Three characters' graphs: the segments linear_segment_bias broadcasts over.
GraphPtr three_meshes() {
  static const CsrGraph a = fixtures::grid_graph(8, 9), b = fixtures::grid_graph(7, 10), c = fixtures::grid_graph(9, 6);
  return share(batch_graphs({&a, &b, &c}));
}

struct Inputs {
  Tensor x, W, s, bias, R;  // R: the loss sum(y * R), so dy = R
};
Inputs inputs(std::int64_t n, std::int64_t segments, std::int64_t k, std::int64_t m) {
  std::mt19937 rng(11);
  return {random_tensor(n, k, rng), random_tensor(k, m, rng), random_tensor(segments, m, rng),
          random_tensor(1, m, rng), random_tensor(n, m, rng)};
}

// y = linear_segment_bias(x, W, linear(s, ...)) when `segment`, else linear(x, W, bias); then the
// loss's backward, under `p` (forward; backward under `backward_p`). Outputs: y, dx, dW, d(s or bias).
std::vector<Tensor> run(const Inputs& in, bool segment, Precision p, Precision backward_p) {
  Var x(in.x.clone(), true), W(in.W.clone(), true), s(in.s.clone(), true), bias(in.bias.clone(), true);
  Var loss;
  Var y;
  {
    ProductPrecisionScope scope(p);
    y = segment ? linear_segment_bias(three_meshes(), x, W, s) : linear(x, W, bias);
    loss = sum(mul(y, Var(in.R)));
  }
  {
    ProductPrecisionScope scope(backward_p);
    backward(loss);
  }
  return {y.value(), x.grad(), W.grad(), segment ? s.grad() : bias.grad()};
}

// |a - b| <= 1.01 * 2^-8 * bound (each operand rounded by at most 2^-9 relative,
// so a product by 2^-8 + 2^-18) + k 2^-23 bound (either side's fp32 sums).
void require_within_rounding(const Tensor& a, const Tensor& b, const ref::Mat& bound, std::int64_t k,
                             const char* what) {
  const double rel = 1.01 * std::ldexp(1.0, -8) + double(k) * std::ldexp(1.0, -23);
  testutil::require_close_bound(a, ref::to_mat(b), bound, rel, 1e-30, what);
}

// Sum of |op(A)(i, p) op(B)(p, j)|: the scale of a product's rounding error.
ref::Mat abs_product(const Tensor& A, bool ta, const Tensor& B, bool tb) {
  ref::Mat bound;
  ref::gemm(ref::to_mat(A), ta, ref::to_mat(B), tb, ref::Mat(ta ? A.cols() : A.rows(), tb ? B.rows() : B.cols()),
            1.0, 0.0, &bound);
  return bound;
}

}  // namespace

TEST_CASE("bf16 products: linear and linear_segment_bias within the operands' rounding of fp32, biases exact",
          "[autograd][bf16]") {
  const GraphPtr g = three_meshes();
  const std::int64_t n = g->num_nodes, k = 40, m = 24;
  const Inputs in = inputs(n, g->num_segments(), k, m);
  if (!bf16_supported()) WARN("this CPU has no AVX512_BF16: bf16 products run fp32 here (checked bitwise)");
  for (bool segment : {false, true}) {
    INFO((segment ? "linear_segment_bias" : "linear"));
    const std::vector<Tensor> f32 = run(in, segment, Precision::fp32, Precision::fp32);
    std::vector<Tensor> b16;
    for (int threads : {1, 2}) {
      testutil::Threads t(threads);
      const std::vector<Tensor> got = run(in, segment, Precision::bf16, Precision::bf16);
      if (threads == 1) {
        b16 = got;
      } else {
        for (std::size_t i = 0; i < got.size(); ++i) REQUIRE(testutil::bitwise_equal(got[i], b16[i]));
      }
    }
    if (!bf16_supported()) {
      for (std::size_t i = 0; i < b16.size(); ++i) REQUIRE(testutil::bitwise_equal(b16[i], f32[i]));
      continue;
    }
    // y: the product over k (plus a bias added in fp32 either way); dx = dy W^T over m; dW = x^T dy over n.
    ref::Mat y_bound = abs_product(in.x, false, in.W, false);
    require_within_rounding(b16[0], f32[0], y_bound, k, "y");
    require_within_rounding(b16[1], f32[1], abs_product(in.R, false, in.W, true), m, "dx");
    require_within_rounding(b16[2], f32[2], abs_product(in.x, true, in.R, false), n, "dW");
    // The bias / segment gradients are sums of dy: no product, bitwise fp32's.
    REQUIRE(testutil::bitwise_equal(b16[3], f32[3]));
    // ... and bf16 did run: most products differ from fp32.
    std::int64_t differ = 0;
    for (std::int64_t i = 0; i < n; ++i)
      for (std::int64_t j = 0; j < m; ++j) differ += b16[0].at(i, j) != f32[0].at(i, j);
    CHECK(differ > n * m / 2);
  }
}

TEST_CASE("bf16 products: backward multiplies in the precision its forward ran in", "[autograd][bf16]") {
  const GraphPtr g = three_meshes();
  const Inputs in = inputs(g->num_nodes, g->num_segments(), 40, 24);
  for (bool segment : {false, true}) {
    INFO((segment ? "linear_segment_bias" : "linear"));
    const std::vector<Tensor> b16 = run(in, segment, Precision::bf16, Precision::bf16);
    const std::vector<Tensor> b16_then_fp32 = run(in, segment, Precision::bf16, Precision::fp32);
    const std::vector<Tensor> f32 = run(in, segment, Precision::fp32, Precision::fp32);
    const std::vector<Tensor> f32_then_b16 = run(in, segment, Precision::fp32, Precision::bf16);
    for (std::size_t i = 0; i < b16.size(); ++i) {
      REQUIRE(testutil::bitwise_equal(b16_then_fp32[i], b16[i]));
      REQUIRE(testutil::bitwise_equal(f32_then_b16[i], f32[i]));
    }
  }
}

TEST_CASE("bf16 products: fp32 without AVX512_BF16 and for products over fewer than 16 terms", "[autograd][bf16]") {
  const GraphPtr g = three_meshes();
  SECTION("a backend without bf16 products (GATCORE_SIMD below AVX-512) runs fp32, and the Trainer says so") {
    testutil::Simd simd(cpu::SimdLevel::avx2 <= cpu::detected_simd_level() ? cpu::SimdLevel::avx2
                                                                            : cpu::SimdLevel::scalar);
    REQUIRE_FALSE(bf16_supported());
    const Inputs in = inputs(g->num_nodes, g->num_segments(), 40, 24);
    for (bool segment : {false, true}) {
      const std::vector<Tensor> b16 = run(in, segment, Precision::bf16, Precision::bf16);
      const std::vector<Tensor> f32 = run(in, segment, Precision::fp32, Precision::fp32);
      for (std::size_t i = 0; i < b16.size(); ++i) REQUIRE(testutil::bitwise_equal(b16[i], f32[i]));
    }
    std::string why;
    CHECK(models::training_precision(Precision::bf16, Device::cpu, &why) == Precision::fp32);
    CHECK_THAT(why, Catch::Contains("no AVX512_BF16") && Catch::Contains("training in fp32"));
    CHECK(models::training_precision(Precision::fp32, Device::cpu, &why) == Precision::fp32);
    CHECK(why.empty());
  }
  SECTION("k < 16 (a bias broadcast through a ones column, matmul(ones, b)) stays fp32") {
    const Inputs in = inputs(g->num_nodes, g->num_segments(), 15, 24);
    for (bool segment : {false, true}) {
      const std::vector<Tensor> b16 = run(in, segment, Precision::bf16, Precision::bf16);
      const std::vector<Tensor> f32 = run(in, segment, Precision::fp32, Precision::fp32);
      for (std::size_t i = 0; i < b16.size(); ++i) REQUIRE(testutil::bitwise_equal(b16[i], f32[i]));
    }
  }
  if (bf16_supported()) {
    std::string why = "x";
    CHECK(models::training_precision(Precision::bf16, Device::cpu, &why) == Precision::bf16);
    CHECK(why.empty());
  }
}

TEST_CASE("bf16 products: batch_norm_act_linear's Linear follows the scope, recorded at forward", "[autograd][bf16]") {
  std::mt19937 rng(12);
  const Tensor x0 = random_tensor(150, 40, rng), g0 = random_tensor(1, 40, rng), b0 = random_tensor(1, 40, rng),
               W0 = random_tensor(40, 24, rng), lb0 = random_tensor(1, 24, rng), R = random_tensor(150, 24, rng);
  auto run = [&](Precision fwd, Precision bwd) {
    Var x(x0.clone(), true), gamma(g0.clone(), true), beta(b0.clone(), true), W(W0.clone(), true),
        lb(lb0.clone(), true);
    BatchNormState st;
    Var y, loss;
    {
      ProductPrecisionScope scope(fwd);
      y = batch_norm_act_linear(x, gamma, beta, st, Activation::leaky_relu, 0.01f, W, lb);
      loss = sum(mul(y, Var(R)));
    }
    {
      ProductPrecisionScope scope(bwd);
      backward(loss);
    }
    return std::vector<Tensor>{y.value(), x.grad(), gamma.grad(), W.grad(), lb.grad()};
  };
  const auto b16 = run(Precision::bf16, Precision::bf16), b16_f32 = run(Precision::bf16, Precision::fp32);
  const auto f32 = run(Precision::fp32, Precision::fp32), f32_b16 = run(Precision::fp32, Precision::bf16);
  for (std::size_t i = 0; i < b16.size(); ++i) {
    INFO("output " << i);
    REQUIRE(testutil::bitwise_equal(b16_f32[i], b16[i]));
    REQUIRE(testutil::bitwise_equal(f32_b16[i], f32[i]));
  }
  if (bf16_supported()) {
    CHECK_FALSE(testutil::bitwise_equal(b16[0], f32[0]));  // the product did run in bf16
    CHECK_FALSE(testutil::bitwise_equal(b16[3], f32[3]));  // and its weight gradient
  } else {
    for (std::size_t i = 0; i < b16.size(); ++i) REQUIRE(testutil::bitwise_equal(b16[i], f32[i]));
  }
}
