// The deploy-time model path (models/deploy.hpp): DeployPlan::run gives
// bitwise models::predict's values on the folded model, for every
// displacement model with a deploy path, with and without BatchNorm and the
// linear skip (the runtime once dropped the skip silently), and refuses models
// without one.
#include <catch2/catch.hpp>

#include <cmath>

#include "gatcore/models/deploy.hpp"
#include "gatcore/models/train.hpp"
#include "src/backends/cpu/inference.hpp"
#include "src/backends/cpu/simd.hpp"
#include "model_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

// A small model of `name`, trained two epochs so BatchNorm statistics and
// affine parameters are non-trivial.
std::unique_ptr<Model> trained(ModelConfig cfg, const std::vector<Sample>& data, Normaliser& norm) {
  auto m = make_model(cfg, 3);
  norm = Normaliser::fit(data, true);
  Trainer t(*m, TrainOptions{2, 1e-3f, Sampling::full}, norm);
  for (int e = 0; e < 2; ++e) t.run_epoch(data);
  return m;
}

ModelConfig small(const std::string& name) {
  ModelConfig c = ModelConfig::defaults(name, 9, 3);
  c.modules = 2;
  c.blocks = 2;
  c.heads = 4;
  c.head_dim = 4;
  c.transform = {8, 8};
  c.head = {16, 8};
  c.gat_layers = 3;
  return c;
}

}  // namespace

TEST_CASE("DeployPlan::run equals models::predict bitwise for every deployable model") {
  const std::vector<Sample> data = {fixtures::wave_sample(9, 7, 0.f), fixtures::wave_sample(9, 7, 0.6f)};
  for (const char* name : {"densegats", "densegats-noself", "densegats-nodense", "origat"}) {
    for (const bool bn : {true, false}) for (const bool skip : {false, true}) {
      INFO("model " << name << ", batch_norm " << bn << ", linear_skip " << skip);
      ModelConfig cfg = small(name);
      cfg.batch_norm = bn;
      cfg.linear_skip = skip;
      Normaliser norm;
      auto m = trained(cfg, data, norm);
      m->fold_batch_norm();
      const Tensor ref = predict(*m, data[1], norm);
      auto dm = make_deploy_model(*m, norm);
      CHECK(deploy_parameter_count(*dm) > 0);
      DeployPlan plan(dm, data[1].graph);
      for (int rep = 0; rep < 2; ++rep) {  // a plan is reusable: the second run gives the same
        plan.input().copy_from_(data[1].features);
        const Tensor& got = plan.run();
        REQUIRE(got.rows() == ref.rows());
        REQUIRE(got.cols() == 3);
        for (std::int64_t i = 0; i < ref.rows(); ++i)
          for (std::int64_t j = 0; j < 3; ++j) REQUIRE(got.at(i, j) == ref.at(i, j));
      }
    }
  }
}

TEST_CASE("a DeployPlan holds the scratch its kernels use: the unfused GAT block's only on that path") {
  const std::vector<Sample> data = {fixtures::wave_sample(9, 7, 0.f), fixtures::wave_sample(9, 7, 0.6f)};
  ModelConfig cfg = small("densegats");
  Normaliser norm;
  auto m = trained(cfg, data, norm);
  m->fold_batch_norm();
  auto dm = make_deploy_model(*m, norm);
  const cpu::SimdLevel level = cpu::simd_level();
  const std::int64_t n = data[1].graph->num_nodes;
  // A GAT block's output columns: the heads', then the self stream's (as nn::GatBlock).
  const std::int64_t kf = std::int64_t(cfg.heads) * cfg.head_dim;
  const std::int64_t width = kf + std::int64_t(std::lround(double(cfg.beta) * double(kf)));
  // At scalar level every block runs unfused: the plan ends up holding its
  // two [n, width] scratch buffers (BatchNorm on: tanhshrink's output too).
  const auto run_at = [&](cpu::SimdLevel l, DeployPlan& plan) {
    cpu::set_simd_level(l);
    const Tensor ref = predict(*m, data[1], norm);
    plan.input().copy_from_(data[1].features);
    const std::vector<float> got = plan.run().to_vector();
    cpu::set_simd_level(level);
    CHECK(got == ref.to_vector());
  };
  DeployPlan plan(dm, data[1].graph);
  const std::int64_t built = plan.scratch_bytes();
  CHECK(built >= (n * (cfg.in_dim + 3)) * 4);  // at least the input and the output
  run_at(level, plan);  // the level this process runs at (GATCORE_SIMD may lower it)
  CHECK(plan.scratch_bytes() == built);  // run() allocates nothing at the level the plan was built for
  // Built for the fused path, the plan holds no unfused buffers; built for
  // the unfused one, it holds them from the start.
  const std::int64_t unfused = cpu::gat_epilogue_supported() ? built + 2 * n * width * 4 : built;
  if (cpu::gat_epilogue_supported()) {
    cpu::set_simd_level(cpu::SimdLevel::scalar);
    DeployPlan built_low(dm, data[1].graph);
    cpu::set_simd_level(level);
    CHECK(built_low.scratch_bytes() == unfused);
  }
  run_at(cpu::SimdLevel::scalar, plan);  // the same plan, now unfused: allocated on the way
  CHECK(plan.scratch_bytes() == unfused);
  run_at(cpu::SimdLevel::scalar, plan);  // the second unfused run reuses them
  CHECK(plan.scratch_bytes() == unfused);
}

TEST_CASE("a bf16 DeployPlan keeps the GAT modules only as bf16: less scratch than fp32, predict's values within bf16") {
  if (!bf16_supported()) {
    WARN("SKIPPED: this CPU has no AVX512_BF16 (a bf16 plan is not built there)");
    return;
  }
  const std::vector<Sample> data = {fixtures::wave_sample(30, 20, 0.f), fixtures::wave_sample(30, 20, 0.6f)};
  ModelConfig cfg = small("densegats");
  cfg.heads = 8;  // the paper's block width, 8 x 8 + 8, and an even transform
  cfg.head_dim = 8;
  cfg.transform = {32, 32};
  Normaliser norm;
  auto m = trained(cfg, data, norm);
  m->fold_batch_norm();
  const Tensor ref = predict(*m, data[1], norm);
  DeployPlan f32(make_deploy_model(*m, norm, Device::cpu, Precision::fp32), data[1].graph);
  DeployPlan b16(make_deploy_model(*m, norm, Device::cpu, Precision::bf16), data[1].graph);
  f32.input().copy_from_(data[1].features);
  f32.run();
  // The fp32 plan's module buffers as floats, a lower bound: every module's
  // block columns, and the first module's input width (32) for each.
  const std::int64_t n = data[1].graph->num_nodes, width = 64 + 8;
  const std::int64_t module_floats = n * 4 * (cfg.modules * (32 + cfg.blocks * width));
  // The bf16 plan holds them as bf16 pairs: at most half a float's bytes per
  // column (rows padded to 16 words, 24 rows more), and only the input
  // transform's 32 columns as floats.
  CHECK(b16.scratch_bytes() < f32.scratch_bytes() - module_floats / 4);
  double err = 0, mag = 0;
  for (int rep = 0; rep < 2; ++rep) {
    b16.input().copy_from_(data[1].features);
    const Tensor& got = b16.run();
    REQUIRE(got.rows() == ref.rows());
    err = mag = 0;
    for (std::int64_t i = 0; i < ref.rows(); ++i)
      for (std::int64_t j = 0; j < ref.cols(); ++j) {
        REQUIRE(std::isfinite(got.at(i, j)));
        err += std::abs(double(got.at(i, j)) - double(ref.at(i, j)));
        mag += std::abs(double(ref.at(i, j)));
      }
  }
  // bf16 operands (2^-9 relative) through 2 x 2 GAT blocks and the head:
  // a few percent of the output's size (test_runtime: 5.9 % on the paper's
  // model), and more than zero (bf16 really ran).
  CHECK(err > 0);
  CHECK(err < 0.08 * mag);
}

TEST_CASE("make_deploy_model refuses models without a deploy path") {
  ModelConfig c = ModelConfig::defaults("neuroskinning", 9, 4);
  auto m = make_model(c, 1);
  REQUIRE_THROWS_WITH(make_deploy_model(*m, Normaliser{}), Catch::Contains("no deploy path"));
  CHECK_FALSE(deployable(c));
  CHECK(deployable(ModelConfig::defaults("densegats", 9, 3)));
}
