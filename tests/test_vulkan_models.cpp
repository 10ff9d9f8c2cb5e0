// Reduced DenseGATs and NeuroSkinning networks built from ops (the structure
// of the models, with tiny widths): a few Adam steps on Vulkan and on the CPU
// from the same initial weights give matching losses, parameters and
// BatchNorm running statistics. Covers DenseNet slots written through `into`
// column views, concat, BatchNorm, dot attention, neighbour mean, segment
// max + broadcast, masked row softmax and the KL loss on a batched graph.
#include "gatcore/ops.hpp"
#include "gatcore/optim.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using vkt::H;

namespace {

struct Params {
  std::vector<Tensor> init;
  std::vector<Var> vars;
  std::mt19937 rng{9};
  // Records a parameter's initial value (CPU); bind() makes the Vars.
  std::size_t add(std::int64_t r, std::int64_t c, float scale) {
    init.push_back(gradcheck::random_tensor(r, c, rng, -scale, scale));
    return init.size() - 1;
  }
  void bind(Device d) {
    vars.clear();
    for (const Tensor& t : init) vars.push_back(Var(to(t.clone(), d), true));  // clone: Adam updates in place
  }
  const Var& operator[](std::size_t k) const { return vars[k]; }
};

// Trains `steps` Adam steps; returns losses and the final parameters (CPU).
template <class Loss>
std::pair<std::vector<float>, std::vector<Tensor>> train(Params& P, Device d, int steps, Loss loss_fn) {
  P.bind(d);
  Adam opt(P.vars, AdamOptions{.lr = 5e-3f});
  std::vector<float> losses;
  for (int s = 0; s < steps; ++s) {
    const auto before = vulkan::stats();
    opt.zero_grad();
    Var loss = loss_fn(d);
    backward(loss);
    opt.step();
    losses.push_back(H(loss.value()).at(0, 0));
    if (d == Device::vulkan) REQUIRE(vulkan::stats().submits == before.submits + 1);
  }
  std::vector<Tensor> out;
  for (const Var& v : P.vars) out.push_back(H(v.value()));
  return {losses, out};
}

void compare(const std::pair<std::vector<float>, std::vector<Tensor>>& c,
             const std::pair<std::vector<float>, std::vector<Tensor>>& g) {
  // float32 on both sides, different summation orders: 1e-4 relative on the
  // losses, 1e-3 relative / 1e-4 absolute on the parameters after the steps.
  for (std::size_t s = 0; s < c.first.size(); ++s) {
    INFO("step " << s);
    REQUIRE(g.first[s] == Approx(c.first[s]).epsilon(1e-4));
  }
  REQUIRE(c.first.back() < c.first.front());
  for (std::size_t k = 0; k < c.second.size(); ++k) {
    INFO("parameter " << k);
    vkt::require_close(c.second[k], g.second[k], 1e-3f, 1e-4f, "parameter");
  }
}

}  // namespace

TEST_CASE("vulkan: reduced DenseGATs trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  GraphPtr g = share(fixtures::grid_graph(10, 8, 1));
  const std::int64_t n = g->num_nodes, in = 5, kT = 6, kOut = 4, kBlocks = 2, heads = 2, F = 2;
  std::mt19937 rng(3);
  Tensor x = gradcheck::random_tensor(n, in, rng), target = gradcheck::random_tensor(n, 3, rng);
  Params P;
  const auto t_W = P.add(in, kT, .5f), t_b = P.add(1, kT, .1f);
  struct Block { std::size_t Wz, al, ar, Ws, bs, gamma, beta; };
  std::vector<Block> blocks;
  for (std::int64_t b = 0; b < kBlocks; ++b) {
    const std::int64_t cin = kT + b * kOut;
    blocks.push_back({P.add(cin, heads * F, .5f), P.add(heads, F, .5f), P.add(heads, F, .5f),
                      P.add(cin, kOut - heads * F, .5f), P.add(1, kOut - heads * F, .1f), P.add(1, kOut, .1f),
                      P.add(1, kOut, .1f)});
    P.init[blocks.back().gamma].fill_(1.0f);
  }
  const auto h_W = P.add(kT + kBlocks * kOut, 3, .5f), h_b = P.add(1, 3, .1f);

  auto run = [&](Device d) {
    std::vector<BatchNormState> bn(kBlocks);
    for (auto& s : bn) {
      s.running_mean = to(Tensor::zeros(1, kOut), d);
      s.running_var = to(Tensor::full(1, kOut, 1.f), d);
    }
    Tensor xd = to(x, d), td = to(target, d);
    auto result = train(P, d, 4, [&](Device dev) {
      Var buf(backend(dev).empty(n, kT + kBlocks * kOut, DType::f32));
      tanh(linear(Var(xd), P[t_W], P[t_b]), buf.cols_slice(0, kT));
      std::int64_t c0 = kT;
      for (std::int64_t b = 0; b < kBlocks; ++b) {
        const Block& B = blocks[b];
        Var inp = buf.cols_slice(0, c0);
        Var agg = gat_additive(g, linear(inp, P[B.Wz], Var{}), P[B.al], P[B.ar], 0.2f);
        Var self = linear(inp, P[B.Ws], P[B.bs]);
        batch_norm(tanhshrink(concat({agg, self})), P[B.gamma], P[B.beta], bn[b], true,
                   buf.cols_slice(c0, c0 + kOut));
        c0 += kOut;
      }
      return mse_loss(linear(buf, P[h_W], P[h_b]), td);
    });
    for (auto& s : bn) {
      result.second.push_back(H(s.running_mean));
      result.second.push_back(H(s.running_var));
    }
    return result;
  };
  compare(run(Device::cpu), run(Device::vulkan));
}

TEST_CASE("vulkan: reduced NeuroSkinning trains like the CPU", "[vulkan]") {
  if (!vkt::ready()) return;
  // A batch of two meshes; a k-nearest neighbour graph for the mean pooling.
  CsrGraph a = fixtures::grid_graph(6, 5, 0), b = fixtures::grid_graph(5, 4, 2);
  GraphPtr g = share(batch_graphs({&a, &b}));
  const std::int64_t n = g->num_nodes, in = 4, C = 8, heads = 2, J = 5;
  std::vector<std::vector<std::int32_t>> nb(static_cast<std::size_t>(n));
  for (std::int32_t i = 0; i < n; ++i)
    for (std::int32_t k = 1; k <= 3; ++k) nb[i].push_back(static_cast<std::int32_t>((i + k * 5) % n));
  GraphPtr knn = share(graph_from_neighbour_lists(n, nb));
  std::mt19937 rng(4);
  Tensor x = gradcheck::random_tensor(n, in, rng);
  Tensor target = gradcheck::random_tensor(n, J, rng, 0.f, 1.f);
  Tensor mask = Tensor::full(1, J, 1.f);
  mask.at(0, 2) = 0.f;
  for (std::int64_t i = 0; i < n; ++i) {
    target.at(i, 2) = 0.f;
    float s = 0;
    for (std::int64_t j = 0; j < J; ++j) s += target.at(i, j);
    for (std::int64_t j = 0; j < J; ++j) target.at(i, j) /= s;
  }
  Params P;
  const auto W0 = P.add(in, C, .5f), b0 = P.add(1, C, .1f), W1 = P.add(C, C, .5f), W2 = P.add(2 * C + C, J, .5f),
             b2 = P.add(1, J, .1f), gamma = P.add(1, C, .1f), beta = P.add(1, C, .1f);
  P.init[gamma].fill_(1.0f);

  auto run = [&](Device d) {
    BatchNormState bn;
    bn.running_mean = to(Tensor::zeros(1, C), d);
    bn.running_var = to(Tensor::full(1, C, 1.f), d);
    Tensor xd = to(x, d), td = to(target, d), md = to(mask, d);
    auto result = train(P, d, 4, [&](Device) {
      Var h = batch_norm(relu(linear(Var(xd), P[W0], P[b0])), P[gamma], P[beta], bn, true);
      Var att = gat_dot(g, linear(h, P[W1], Var{}), heads, 0.5f);
      Var local = neighbour_mean(knn, att);
      Var global = broadcast_segments(g, segment_max(g, att));
      Var logits = linear(concat({att, local, global}), P[W2], P[b2]);
      return kl_div_loss(row_softmax(logits, md), td);
    });
    result.second.push_back(H(bn.running_mean));
    result.second.push_back(H(bn.running_var));
    return result;
  };
  compare(run(Device::cpu), run(Device::vulkan));
}
