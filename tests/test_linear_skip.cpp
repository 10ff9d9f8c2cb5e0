// DenseGATs' linear skip (ModelConfig::linear_skip, models/linear_skip.hpp):
// the configuration key and old configurations, the untrained network equals
// the skip, the least-squares fit recovers a linear target exactly, finite-
// difference gradients through the skip and the residual head, checkpoints,
// and a short training run that ends below the linear fit on a nonlinear
// target (the network beats its own linear probe).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>

#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/linear_skip.hpp"
#include "gatcore/models/train.hpp"
#include "gradcheck.hpp"
#include "model_gradcheck.hpp"
#include "model_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

ModelConfig small_skip_config() {
  ModelConfig c = ModelConfig::defaults("densegats", 9);
  c.modules = 1;
  c.blocks = 2;
  c.heads = 2;
  c.head_dim = 4;
  c.beta = 0.5f;
  c.transform = {8};
  c.head = {8};
  c.linear_skip = true;
  return c;
}

Batch batch_of(const std::vector<Sample>& s, const Normaliser& norm) {
  std::vector<const Sample*> p;
  std::vector<std::vector<std::int32_t>> sel;
  for (const auto& x : s) p.push_back(&x), sel.emplace_back();
  return make_batch(p, sel, norm, {});
}

// A target that is exactly linear in the raw features.
Sample linear_target(Sample s) {
  for (std::int64_t i = 0; i < s.features.rows(); ++i)
    for (int k = 0; k < 3; ++k) {
      double t = 0.01 * (k + 1);
      for (std::int64_t c = 0; c < s.features.cols(); ++c) t += 0.1 * std::sin(1.0 + c + 3.0 * k) * s.features.at(i, c);
      s.target.at(i, k) = float(t);
    }
  return s;
}

double max_abs_diff(const Tensor& a, const Tensor& b) {
  double m = 0;
  for (std::int64_t i = 0; i < a.rows(); ++i)
    for (std::int64_t j = 0; j < a.cols(); ++j) m = std::max(m, std::abs(double(a.at(i, j)) - b.at(i, j)));
  return m;
}

// A nonlinear target of the wave features (fixtures::wave_sample): the
// linear fit leaves a residual the graph part has to learn. Fits `m`'s skip,
// trains `epochs` full-batch epochs; {eval MSE at the fit, after training}.
std::pair<double, double> train_from_fit(Model& m, int epochs, const Normaliser& norm, const std::vector<Sample>& data) {
  const LinearMap f = fit_linear_skip(m, data, norm);
  INFO("linear fit MSE " << f.mse_after << " of " << f.mse_before);
  REQUIRE(f.mse_after > 0.01 * f.mse_before);  // not linear: something left for the network
  REQUIRE(f.mse_after < f.mse_before);
  TrainOptions o = TrainOptions::defaults_for(m.config());
  o.sampling = Sampling::full;
  o.batch_size = 3;
  o.lr = 3e-3f;
  Trainer t(m, o, norm);
  const double start = t.evaluate(data);
  // evaluate() averages per sample, the fit over all vertices: close, not equal.
  CHECK(start == Approx(f.mse_after).epsilon(0.25));
  for (int e = 0; e < epochs; ++e) t.run_epoch(data);
  return {start, t.evaluate(data)};
}

std::vector<Sample> wave_data() {
  return {fixtures::wave_sample(8, 6, 0.f), fixtures::wave_sample(8, 6, 0.6f), fixtures::wave_sample(7, 6, 1.2f)};
}

}  // namespace

TEST_CASE("linear_skip: a configuration key, off by default and for configurations written before it") {
  CHECK_FALSE(ModelConfig::defaults("densegats", 9).linear_skip);
  CHECK_FALSE(ModelConfig::from_text("name = densegats\nin_dim = 9\n").linear_skip);
  ModelConfig c = small_skip_config();
  CHECK(ModelConfig::from_text(c.to_text()) == c);
  CHECK_THROWS_WITH(ModelConfig::from_text("linear_skip = maybe\n"), Catch::Contains("bad value 'maybe' for 'linear_skip'"));
  // Without the key the parameter set is the paper's (old checkpoints load unchanged).
  ModelConfig plain = c;
  plain.linear_skip = false;
  CHECK_FALSE(make_model(plain, 1)->registry().find_param("skip.W"));
  auto m = make_model(c, 1);
  REQUIRE(m->registry().find_param("skip.W"));
  CHECK(m->registry().find_param("skip.W")->value().rows() == 9);
  CHECK(m->registry().find_param("skip.b")->value().cols() == 3);
  ModelConfig w = ModelConfig::defaults("neuroskinning", 9, 5);
  w.name = "densegats";  // the densegats family with the weights task
  w.linear_skip = true;
  CHECK_THROWS_WITH(make_model(w, 1), Catch::Contains("linear_skip needs the displacement task"));
}

TEST_CASE("linear_skip: the untrained network is the skip, and the least-squares fit recovers a linear target") {
  std::vector<Sample> data = {linear_target(fixtures::wave_sample(8, 6, 0.f)),
                              linear_target(fixtures::wave_sample(7, 6, 0.9f))};
  const Normaliser norm = Normaliser::fit(data, true);
  auto m = make_model(small_skip_config(), 3);
  const Batch b = batch_of(data, norm);
  {
    NoGradGuard ng;
    const Tensor y = m->forward(b, false).value();
    CHECK(max_abs_diff(y, Tensor::zeros(y.rows(), 3)) == 0.0);  // zero head, zero skip
  }
  const LinearMap f = fit_linear_skip(*m, data, norm);
  CHECK(f.rows == 48 + 42);
  CHECK(f.mse_before > 0.1);
  CHECK(f.mse_after < 1e-8 * f.mse_before);
  NoGradGuard ng;
  const Tensor y = m->forward(b, false).value();
  CHECK(max_abs_diff(y, b.target) < 1e-4);
  // predict() de-normalises: the raw target back.
  CHECK(max_abs_diff(predict(*m, data[1], norm), data[1].target) < 1e-4);
  CHECK(max_abs_diff(predict_linear(f, data[1], norm), data[1].target) < 1e-4);

  auto plain = make_model(ModelConfig::defaults("densegats", 9), 3);
  CHECK_THROWS_WITH(fit_linear_skip(*plain, data, norm), Catch::Contains("has no linear skip"));
  CHECK_THROWS_WITH(fit_linear_skip(*m, {}, norm), Catch::Contains("no samples"));
  Sample narrow = data[0];
  narrow.features = Tensor::zeros(narrow.features.rows(), 4);
  CHECK_THROWS_WITH(fit_linear_skip(*m, {narrow}, Normaliser{}), Catch::Contains("has 4 features"));
}

TEST_CASE("linear_skip: finite-difference gradients through the skip and the residual head") {
  Sample s = fixtures::wave_sample(6, 5, 0.3f, false);
  const Normaliser norm = Normaliser::fit({s}, true);
  auto m = make_model(small_skip_config(), 5);
  // Away from the zero start so that every parameter has a gradient.
  std::mt19937 rng(4);
  for (const char* name : {"skip.W", "skip.b", "head.1.W"}) {
    const Var* p = m->registry().find_param(name);
    REQUIRE(p);
    p->value().copy_from_(gradcheck::random_tensor(p->value().rows(), p->value().cols(), rng, -0.5f, 0.5f));
  }
  const Batch b = batch_of({s}, norm);
  const auto is_skip = [](const std::string& n) { return n.rfind("skip.", 0) == 0 || n == "head.1.W"; };
  // Every entry of the skip and the output layer; the skip is linear in its parameters: tight.
  std::int64_t checked = 0;
  for (const fixtures::GradEntry& e : fixtures::model_gradcheck(*m, b, is_skip)) {
    ++checked;
    if (e.param.rfind("skip.", 0) == 0) CHECK(e.analytic == Approx(e.numeric).margin(2e-3).epsilon(2e-3));
  }
  CHECK(checked > 30);
}

TEST_CASE("linear_skip: checkpoints keep the skip, and training from the fit ends below the linear fit") {
  const std::vector<Sample> data = wave_data();
  const Normaliser norm = Normaliser::fit(data, true);
  auto m = make_model(small_skip_config(), 7);
  const auto [start, end] = train_from_fit(*m, 150, norm, data);
  INFO("eval MSE after training " << end << " (linear fit " << start << ")");
  CHECK(end < 0.5 * start);

  const std::string path = (std::filesystem::temp_directory_path() / "gatcore_linear_skip.gcm").string();
  save_checkpoint(path, *m, norm);
  LoadedModel l = load_checkpoint(path);
  CHECK(l.model->config().linear_skip);
  CHECK(l.model->registry().find_param("skip.W")->value().to_vector() ==
        m->registry().find_param("skip.W")->value().to_vector());
  CHECK(max_abs_diff(predict(*l.model, data[0], l.norm), predict(*m, data[0], norm)) == 0.0);
  std::remove(path.c_str());
}

TEST_CASE("linear_skip on Ori.GAT (the distillation student): zero start, the fit, gradients, training below the fit") {
  ModelConfig c = ModelConfig::defaults("origat", 9);
  c.gat_layers = 2;
  c.heads = 2;
  c.head_dim = 4;
  c.linear_skip = true;
  std::vector<Sample> lin = {linear_target(fixtures::wave_sample(8, 6, 0.f)),
                             linear_target(fixtures::wave_sample(7, 6, 0.9f))};
  {
    const Normaliser norm = Normaliser::fit(lin, true);
    auto m = make_model(c, 3);
    REQUIRE(m->registry().find_param("skip.W"));
    CHECK(m->registry().find_param("layers.1.W")->value().to_vector() ==
          std::vector<float>(std::size_t(m->registry().find_param("layers.1.W")->value().numel()), 0.f));
    const Batch b = batch_of(lin, norm);
    NoGradGuard ng;
    const Tensor y0 = m->forward(b, false).value();
    CHECK(max_abs_diff(y0, Tensor::zeros(y0.rows(), 3)) == 0.0);
    const LinearMap f = fit_linear_skip(*m, lin, norm);
    CHECK(f.mse_after < 1e-8 * f.mse_before);
    CHECK(max_abs_diff(predict(*m, lin[1], norm), lin[1].target) < 1e-4);
  }
  {  // gradients: the zero last layer gets one (it must leave zero), the skip's are exact
    Sample s = fixtures::wave_sample(6, 5, 0.3f, false);
    const Normaliser norm = Normaliser::fit({s}, true);
    auto m = make_model(c, 5);
    std::mt19937 rng(2);
    for (const char* name : {"skip.W", "skip.b"}) {
      const Var* p = m->registry().find_param(name);
      p->value().copy_from_(gradcheck::random_tensor(p->value().rows(), p->value().cols(), rng, -0.5f, 0.5f));
    }
    const Batch b = batch_of({s}, norm);
    bool last_moves = false;
    std::int64_t checked = 0;
    for (const fixtures::GradEntry& e :
         fixtures::model_gradcheck(*m, b, [](const std::string& n) { return n.rfind("skip.", 0) == 0 || n == "layers.1.W"; })) {
      ++checked;
      CHECK(e.analytic == Approx(e.numeric).margin(2e-3).epsilon(2e-3));
      if (e.param == "layers.1.W" && std::abs(e.analytic) > 1e-4) last_moves = true;
    }
    CHECK(checked > 30);
    CHECK(last_moves);
  }
  // Nonlinear target: training from the fit ends below it.
  const std::vector<Sample> data = wave_data();
  const Normaliser norm = Normaliser::fit(data, true);
  auto m = make_model(c, 7);
  const auto [start, end] = train_from_fit(*m, 200, norm, data);
  INFO("Ori.GAT eval MSE after training " << end << " (linear fit " << start << ")");
  CHECK(end < 0.7 * start);
}
