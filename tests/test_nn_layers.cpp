// The layers of include/gatcore/nn: registry names, finite-difference
// gradients of every layer, BatchNorm folding, dropout.
#include <catch2/catch.hpp>

#include "gatcore/nn/dense_module.hpp"
#include "gatcore/nn/gc_unit.hpp"
#include "gatcore/nn/mlp.hpp"
#include "gatcore/nn/pooling.hpp"
#include "gatcore/models/train.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::nn;

namespace {

// Checks d(Σ R⊙f())/dp for every registered parameter (sampled entries)
// against central differences. f must be deterministic. Chains of
// BatchNorm over few rows and attention are curved enough that a step of
// 1e-2 biases the difference quotient: deeper checks use 1e-3.
void check_params(const std::string& what, Registry& reg, const std::function<Var()>& f, double rtol = 3e-2,
                  double atol = 3e-3, float step = 1e-2f) {
  INFO("layer " << what);
  std::mt19937 rng(99);
  for (auto& p : reg.params) p.var.zero_grad();
  Var y = f();
  Tensor R = gradcheck::random_tensor(y.rows(), y.cols(), rng);
  backward(sum(mul(y, Var(R))));
  auto value = [&] {
    NoGradGuard ng;
    Var v = f();
    double s = 0;
    for (std::int64_t i = 0; i < v.rows(); ++i)
      for (std::int64_t j = 0; j < v.cols(); ++j) s += double(v.value().at(i, j)) * R.at(i, j);
    return s;
  };
  for (auto& p : reg.params) {
    Tensor g = p.var.grad();
    REQUIRE(g.defined());
    const Tensor& x = p.var.value();
    for (int t = 0; t < 6; ++t) {
      const std::int64_t id = std::int64_t(rng() % std::uint64_t(x.numel()));
      const std::int64_t r = id / x.cols(), c = id % x.cols();
      const float orig = x.at(r, c);
      x.at(r, c) = orig + step;
      const double lp = value();
      x.at(r, c) = orig - step;
      const double lm = value();
      x.at(r, c) = orig;
      const double fd = (lp - lm) / (2.0 * step), an = g.at(r, c);
      INFO(p.name << " (" << r << ", " << c << "): analytic " << an << " vs fd " << fd);
      CHECK(std::abs(an - fd) <= atol + rtol * std::max(std::abs(an), std::abs(fd)));
    }
  }
}

}  // namespace

TEST_CASE("registry gives hierarchical names and rejects duplicates") {
  Registry reg;
  Rng rng(1);
  Scope root{&reg, ""};
  GatBlock b(root.sub("modules").sub(1).sub("blocks").sub(3), 16, GatBlockOptions{}, rng);
  REQUIRE(reg.find_param("modules.1.blocks.3.att_src"));
  REQUIRE(reg.find_param("modules.1.blocks.3.self.W"));
  REQUIRE(reg.find_buffer("modules.1.blocks.3.bn.running_var"));
  CHECK(b.out() == 72);
  CHECK(b.self_width == 8);
  CHECK_THROWS_WITH(root.sub("modules").sub(1).sub("blocks").sub(3).param("W", Tensor::zeros(1, 1)),
                    Catch::Contains("duplicate name 'modules.1.blocks.3.W'"));
}

TEST_CASE("seeded initialisation is reproducible and Glorot-bounded") {
  Rng a(5), b(5);
  Tensor wa = init_weight(64, 32, Init::glorot, a), wb = init_weight(64, 32, Init::glorot, b);
  CHECK(wa.to_vector() == wb.to_vector());
  const float bound = std::sqrt(6.f / 96.f);
  for (float v : wa.to_vector()) CHECK(std::abs(v) <= bound);
}

TEST_CASE("gradients of Linear, BatchNorm1d and DenseLayer match finite differences") {
  std::mt19937 r(3);
  Tensor x = gradcheck::random_tensor(12, 5, r);
  Registry reg;
  Rng rng(2);
  Scope s{&reg, ""};
  DenseLayer l(s.sub("dense"), 5, 6, DenseLayerOptions{Activation::tanh, 0.f, true, 0.f, Init::glorot}, rng);
  Linear lin(s.sub("lin"), 6, 4, rng);
  Rng drop(0);
  check_params("DenseLayer+Linear", reg, [&] { return lin.forward(l.forward(Var(x), true, drop)); });
}

TEST_CASE("a training MLP runs BatchNorm → LeakyReLU fused with the next Linear: the unfused layers' values and "
          "gradients, a shorter tape") {
  std::mt19937 r(4);
  const Tensor x = gradcheck::random_tensor(300, 9, r, -2.f, 2.f);
  const Tensor R = gradcheck::random_tensor(300, 5, r);
  for (float dropout : {0.f, 0.3f}) {
    INFO("dropout " << dropout);
    Registry reg;
    Rng init(5);
    Mlp mlp(Scope{&reg, ""}, 9, {16, 12, 8}, 5, DenseLayerOptions{Activation::leaky_relu, 0.1f, true, dropout},
            init);
    // The same layers unfused, by hand: Linear → batch_norm → activation → [dropout].
    BatchNormState st[3];
    Rng d0(7), d1(7);
    Var y = Var(x);
    for (std::size_t k = 0; k < 3; ++k) {
      const DenseLayer& l = mlp.layers[k];
      st[k] = l.bn.state;
      st[k].running_mean = l.bn.state.running_mean.clone(), st[k].running_var = l.bn.state.running_var.clone();
      y = activation(Activation::leaky_relu, batch_norm(l.lin.forward(y), l.bn.gamma, l.bn.beta, st[k], true), 0.1f);
      if (dropout > 0.f) y = Dropout{dropout}.forward(y, true, d0);
    }
    y = mlp.last.forward(y);
    const std::size_t unfused_nodes = current_tape().size();
    backward(sum(mul(y, Var(R))));
    std::vector<Tensor> want;
    for (auto& p : reg.params) want.push_back(p.var.grad().clone()), p.var.zero_grad();

    const Var out = mlp.forward(Var(x), true, d1);
    const std::size_t fused_nodes = current_tape().size();
    // Without dropout: linear + 3 × batch_norm_act_linear instead of 3 × (linear, batch_norm, activation) + linear;
    // with dropout: batch_norm_act in place of each (batch_norm, activation) pair.
    CHECK(unfused_nodes == (dropout > 0.f ? 13 : 10));
    CHECK(fused_nodes == (dropout > 0.f ? 10 : 4));
    backward(sum(mul(out, Var(R))));
    for (std::int64_t i = 0; i < y.rows(); ++i)
      for (std::int64_t j = 0; j < y.cols(); ++j)
        REQUIRE(out.value().at(i, j) == Approx(y.value().at(i, j)).margin(1e-5));
    for (std::size_t k = 0; k < 3; ++k)
      for (std::int64_t c = 0; c < mlp.layers[k].out(); ++c) {
        CHECK(mlp.layers[k].bn.state.running_mean.at(0, c) == st[k].running_mean.at(0, c));
        CHECK(mlp.layers[k].bn.state.running_var.at(0, c) == st[k].running_var.at(0, c));
      }
    for (std::size_t p = 0; p < reg.params.size(); ++p) {
      INFO(reg.params[p].name);
      const Tensor g = reg.params[p].var.grad();
      REQUIRE(g.defined());
      for (std::int64_t i = 0; i < g.rows(); ++i)
        for (std::int64_t j = 0; j < g.cols(); ++j)
          REQUIRE(g.at(i, j) == Approx(want[p].at(i, j)).margin(1e-4 * (1.0 + std::abs(want[p].at(i, j)))));
    }
    // Eval (and folded) forward is the unfused path, unchanged.
    CHECK(!mlp.layers[0].fuses_with_next(false));
  }
}

TEST_CASE("gradients of the GAT block and a dense module (2 blocks) match finite differences") {
  auto g = share(fixtures::grid_graph(6, 5));
  std::mt19937 r(4);
  Tensor x = gradcheck::random_tensor(30, 6, r);
  Registry reg;
  Rng rng(3);
  GatBlockOptions o{2, 3, 0.5f, 0.2f, true};
  DenseModule m(Scope{&reg, "modules.0."}, 6, 2, o, true, rng);
  CHECK(m.buffer_width() == 6 + 2 * 9);
  check_params("DenseModule", reg, [&] {
    Var buf = m.make_buffer(30);
    copy_into(Var(x), DenseModule::input_slot(buf, 6));
    return m.forward(g, buf, true);
  }, 5e-2, 1e-2, 1e-3f);
  // No-dense ablation reads only the previous block.
  Registry reg2;
  DenseModule nd(Scope{&reg2, ""}, 6, 2, o, false, rng);
  CHECK(nd.out() == 9);
  check_params("DenseModule nodense", reg2, [&] {
    Var buf = nd.make_buffer(30);
    copy_into(Var(x), DenseModule::input_slot(buf, 6));
    return nd.forward(g, buf, true);
  }, 5e-2, 1e-2, 1e-3f);
}

TEST_CASE("gradients of the NeuroSkinning GC unit and global max pool match finite differences") {
  auto g = share(fixtures::grid_graph(4, 3));
  auto nbr = share(graph_from_neighbour_lists(12, models::hop_neighbours(*g, 4)));
  std::mt19937 r(5);
  Tensor x = gradcheck::random_tensor(12, 5, r);
  Registry reg;
  Rng rng(4);
  GcUnit u(Scope{&reg, "gc.0."}, 5, GcUnitOptions{2, 3, 4, true, 0.1f}, rng);
  CHECK(u.out() == 5 + 2 * 6);
  Linear l(Scope{&reg, "lin."}, 17, 3, rng);
  check_params("GcUnit + max pool", reg, [&] { return global_max_broadcast(g, l.forward(u.forward(g, nbr, Var(x)))); });
}

TEST_CASE("folding BatchNorm into the preceding Linear gives the same eval outputs") {
  std::mt19937 r(6);
  Tensor x = gradcheck::random_tensor(40, 7, r);
  Registry reg;
  Rng rng(5);
  Mlp mlp(Scope{&reg, "mlp."}, 7, {16, 8}, 3, DenseLayerOptions{Activation::leaky_relu, 0.1f, true, 0.f, Init::glorot},
          rng);
  for (int k = 0; k < 5; ++k) mlp.forward(Var(gradcheck::random_tensor(40, 7, r)), true, rng);  // running stats
  // Make the affine parameters non-trivial.
  for (auto& p : reg.params)
    if (p.name.find("bn.") != std::string::npos)
      for (std::int64_t j = 0; j < p.var.cols(); ++j) p.var.value().at(0, j) += 0.3f * float(j % 3) - 0.2f;
  NoGradGuard ng;
  Tensor ref = mlp.forward(Var(x), false, rng).value().clone();
  mlp.fold();
  Tensor got = mlp.forward(Var(x), false, rng).value();
  for (std::int64_t i = 0; i < ref.rows(); ++i)
    for (std::int64_t j = 0; j < ref.cols(); ++j)
      CHECK(got.at(i, j) == Approx(ref.at(i, j)).epsilon(1e-5).margin(1e-6));
  CHECK_THROWS_WITH(mlp.forward(Var(x), true, rng), Catch::Contains("folded"));
}

TEST_CASE("dropout is seeded, scales kept entries and is the identity in eval") {
  Tensor x = Tensor::full(50, 40, 1.f);
  Rng a(7), b(7);
  Dropout d{0.6f};
  Tensor ya = d.forward(Var(x), true, a).value(), yb = d.forward(Var(x), true, b).value();
  CHECK(ya.to_vector() == yb.to_vector());
  int zeros = 0;
  for (float v : ya.to_vector()) {
    CHECK((v == 0.f || v == Approx(2.5f)));
    zeros += v == 0.f;
  }
  CHECK(zeros > 1000);
  CHECK(zeros < 1400);
  CHECK(d.forward(Var(x), false, a).value().to_vector() == x.to_vector());
}
