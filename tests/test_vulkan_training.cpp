// A short training run of a small 2-layer GAT built from ops: the same initial
// weights trained with Adam on Vulkan and on the CPU give matching losses and
// parameters. Each Vulkan step is one submission (the loss read) and, after a
// warm-up step, allocates no device memory; every tensor stays on the device,
// so no CPU fallback can happen inside the step (device tensors are not
// host-addressable: a CPU kernel on one would throw).
#include "gatcore/ops.hpp"
#include "gatcore/optim.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using vkt::H;

namespace {

struct Model {
  Var W1, al1, ar1, W2, b2;
  std::vector<Var> params() const { return {W1, al1, ar1, W2, b2}; }
};

Model make_model(const std::vector<Tensor>& init, Device d) {
  // clone(): to(t, cpu) is a no-op view and Adam updates in place.
  auto P = [&](std::size_t k) { return Var(to(init[k].clone(), d), true); };
  return {P(0), P(1), P(2), P(3), P(4)};
}

Var forward(const Model& m, const GraphPtr& g, const Var& x) {
  Var h = tanh(gat_additive(g, linear(x, m.W1, Var{}), m.al1, m.ar1));     // [n, 2*8]
  Var z = linear(h, m.W2, m.b2);                                             // [n, 2*4]
  Var alpha = edge_softmax_dot(g, z, 2, 0.5f);
  return leaky_relu(aggregate(g, alpha, z), 0.1f);
}

}  // namespace

TEST_CASE("vulkan: Adam training of a 2-layer GAT matches the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;  // under the *_smallbind hook: the step ran the large-operand paths
  std::mt19937 rng(7);
  GraphPtr g = share(fixtures::grid_graph(12, 10, 2));
  const std::int64_t n = g->num_nodes;
  Tensor x = gradcheck::random_tensor(n, 6, rng), target = gradcheck::random_tensor(n, 8, rng);
  std::vector<Tensor> init = {
      gradcheck::random_tensor(6, 16, rng, -.5f, .5f), gradcheck::random_tensor(2, 8, rng, -.5f, .5f),
      gradcheck::random_tensor(2, 8, rng, -.5f, .5f),  gradcheck::random_tensor(16, 8, rng, -.5f, .5f),
      gradcheck::random_tensor(1, 8, rng, -.1f, .1f)};
  const int steps = 6;

  auto train = [&](Device d, std::vector<float>& losses) {
    Model m = make_model(init, d);
    Adam opt(m.params(), AdamOptions{.lr = 1e-2f});
    Var xv(to(x, d));
    Tensor t = to(target, d);
    std::uint64_t allocs_after_warmup = 0;
    for (int s = 0; s < steps; ++s) {
      const auto before = vulkan::stats();
      opt.zero_grad();
      Var loss = mse_loss(forward(m, g, xv), t);
      backward(loss);
      opt.step();
      losses.push_back(H(loss.value()).at(0, 0));
      if (d == Device::vulkan) {
        REQUIRE(loss.device() == Device::vulkan);
        for (const Var& p : m.params()) REQUIRE(p.grad().device() == Device::vulkan);
        // The whole forward + backward + Adam step: one submission.
        REQUIRE(vulkan::stats().submits == before.submits + 1);
        if (s == 1) allocs_after_warmup = vulkan::stats().device_allocations;
        if (s > 1) REQUIRE(vulkan::stats().device_allocations == allocs_after_warmup);
      }
    }
    std::vector<Tensor> out;
    for (const Var& p : m.params()) out.push_back(H(p.value()));
    return out;
  };
  std::vector<float> lc, lg;
  auto pc = train(Device::cpu, lc);
  auto pg = train(Device::vulkan, lg);
  // Tolerance: float32 on both sides with different summation orders; after
  // 6 Adam steps at lr 1e-2 losses agree to 1e-4 relative, parameters to 1e-4.
  for (int s = 0; s < steps; ++s) {
    INFO("step " << s);
    REQUIRE(lg[s] == Approx(lc[s]).epsilon(1e-4));
  }
  REQUIRE(lc.back() < lc.front());
  for (std::size_t k = 0; k < pc.size(); ++k) vkt::require_close(pc[k], pg[k], 1e-3f, 1e-4f, "parameter");
  large_paths.require();
}
