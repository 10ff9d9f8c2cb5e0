// The deploy-time model path (models/deploy.hpp): DeployPlan::run gives
// bitwise models::predict's values on the folded model, for every
// displacement model with a deploy path, with and without BatchNorm and the
// linear skip (the runtime once dropped the skip silently), and refuses models
// without one.
#include <catch2/catch.hpp>

#include "gatcore/models/deploy.hpp"
#include "gatcore/models/train.hpp"
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

TEST_CASE("make_deploy_model refuses models without a deploy path") {
  ModelConfig c = ModelConfig::defaults("neuroskinning", 9, 4);
  auto m = make_model(c, 1);
  REQUIRE_THROWS_WITH(make_deploy_model(*m, Normaliser{}), Catch::Contains("no deploy path"));
  CHECK_FALSE(deployable(c));
  CHECK(deployable(ModelConfig::defaults("densegats", 9, 3)));
}
