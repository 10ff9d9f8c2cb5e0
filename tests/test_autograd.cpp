// Finite-difference gradient checks of every differentiable op, a 3-layer
// multi-head GAT end to end, and the tape's bookkeeping rules.
#include <catch2/catch.hpp>

#include "gatcore/ops.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"

using namespace gatcore;
using gradcheck::random_tensor;

namespace {
std::mt19937 rng_for(int seed) { return std::mt19937(seed); }
GraphPtr small_mesh(int isolated = 1) { return share(fixtures::grid_graph(4, 3, isolated)); }
}  // namespace

TEST_CASE("gradcheck dense ops", "[autograd]") {
  auto rng = rng_for(1);
  SECTION("linear with bias, strided input") {
    Tensor wide = random_tensor(7, 9, rng);
    gradcheck::check("linear", [](const std::vector<Var>& v) { return linear(v[0].cols_slice(2, 7), v[1], v[2]); },
                     {wide, random_tensor(5, 4, rng), random_tensor(1, 4, rng)});
  }
  SECTION("matmul") {
    gradcheck::check("matmul", [](const std::vector<Var>& v) { return matmul(v[0], v[1]); },
                     {random_tensor(6, 3, rng), random_tensor(3, 5, rng)});
  }
  SECTION("add sub mul scale") {
    auto a = random_tensor(5, 4, rng), b = random_tensor(5, 4, rng);
    gradcheck::check("add", [](const std::vector<Var>& v) { return add(v[0], v[1]); }, {a, b});
    gradcheck::check("sub", [](const std::vector<Var>& v) { return sub(v[0], v[1]); }, {a, b});
    gradcheck::check("mul", [](const std::vector<Var>& v) { return mul(v[0], v[1]); }, {a, b});
    gradcheck::check("scale", [](const std::vector<Var>& v) { return scale(v[0], -2.5f); }, {a});
  }
  SECTION("concat and column slices") {
    gradcheck::check("concat",
                     [](const std::vector<Var>& v) {
                       return concat({v[0], v[1].cols_slice(1, 3), tanh(v[0])});
                     },
                     {random_tensor(4, 3, rng), random_tensor(4, 5, rng)});
  }
  SECTION("activations") {
    // Keep away from the kinks of relu / leaky relu.
    Tensor x = random_tensor(6, 5, rng, 0.05f, 1.0f);
    for (std::int64_t i = 0; i < x.rows(); ++i)
      for (std::int64_t j = 0; j < x.cols(); ++j)
        if ((i + j) % 2) x.at(i, j) = -x.at(i, j);
    gradcheck::check("tanh", [](const std::vector<Var>& v) { return tanh(v[0]); }, {x});
    gradcheck::check("tanhshrink", [](const std::vector<Var>& v) { return tanhshrink(v[0]); }, {x});
    gradcheck::check("relu", [](const std::vector<Var>& v) { return relu(v[0]); }, {x});
    gradcheck::check("leaky_relu", [](const std::vector<Var>& v) { return leaky_relu(v[0], 0.2f); }, {x});
  }
  SECTION("row softmax, with and without mask") {
    Tensor x = random_tensor(5, 6, rng, -2.f, 2.f);
    gradcheck::check("row_softmax", [](const std::vector<Var>& v) { return row_softmax(v[0]); }, {x});
    Tensor mask = Tensor::from(1, 6, {1, 0, 1, 1, 0, 1});
    gradcheck::check("row_softmax masked", [mask](const std::vector<Var>& v) { return row_softmax(v[0], mask); },
                     {x});
  }
  SECTION("batch norm, training and eval") {
    Tensor x = random_tensor(9, 4, rng, -2.f, 2.f);
    Tensor gamma = random_tensor(1, 4, rng, 0.5f, 1.5f), beta = random_tensor(1, 4, rng);
    auto st = std::make_shared<BatchNormState>();
    gradcheck::check("batch_norm train",
                     [st](const std::vector<Var>& v) { return batch_norm(v[0], v[1], v[2], *st, true); },
                     {x, gamma, beta});
    auto ev = std::make_shared<BatchNormState>();
    ev->running_mean = random_tensor(1, 4, rng);
    ev->running_var = random_tensor(1, 4, rng, 0.5f, 2.0f);
    gradcheck::check("batch_norm eval",
                     [ev](const std::vector<Var>& v) { return batch_norm(v[0], v[1], v[2], *ev, false); },
                     {x, gamma, beta});
  }
  SECTION("batch norm fused with an activation, and with the next linear") {
    Tensor x = random_tensor(9, 4, rng, -2.f, 2.f);
    Tensor gamma = random_tensor(1, 4, rng, 0.5f, 1.5f), beta = random_tensor(1, 4, rng);
    Tensor W = random_tensor(4, 3, rng), b = random_tensor(1, 3, rng);
    auto st = std::make_shared<BatchNormState>();
    for (Activation f : {Activation::leaky_relu, Activation::relu, Activation::identity}) {
      gradcheck::check(std::string("batch_norm_act ") + activation_name(f),
                       [st, f](const std::vector<Var>& v) { return batch_norm_act(v[0], v[1], v[2], *st, f, 0.1f); },
                       {x, gamma, beta});
      gradcheck::check(std::string("batch_norm_act_linear ") + activation_name(f),
                       [st, f](const std::vector<Var>& v) {
                         return batch_norm_act_linear(v[0], v[1], v[2], *st, f, 0.1f, v[3], v[4]);
                       },
                       {x, gamma, beta, W, b});
    }
  }
  SECTION("sum, mean, losses") {
    Tensor x = random_tensor(4, 3, rng);
    gradcheck::check("sum", [](const std::vector<Var>& v) { return sum(v[0]); }, {x});
    gradcheck::check("mean", [](const std::vector<Var>& v) { return mean(v[0]); }, {x});
    Tensor t = random_tensor(4, 3, rng);
    gradcheck::check("mse", [t](const std::vector<Var>& v) { return mse_loss(v[0], t); }, {x});
    Tensor p = random_tensor(4, 3, rng, 0.1f, 1.0f), q = random_tensor(4, 3, rng, 0.0f, 1.0f);
    q.at(0, 1) = 0.0f;  // a zero target contributes nothing
    gradcheck::check("kl_div", [q](const std::vector<Var>& v) { return kl_div_loss(v[0], q); }, {p},
                     {1e-3f, 3e-2, 3e-3, 48});
  }
}

TEST_CASE("gradcheck graph attention ops", "[autograd]") {
  auto rng = rng_for(2);
  GraphPtr g = small_mesh();
  const std::int64_t n = g->num_nodes;
  const int H = 3, F = 2;
  Tensor z = random_tensor(n, H * F, rng), al = random_tensor(H, F, rng), ar = random_tensor(H, F, rng);
  SECTION("attention projection") {
    gradcheck::check("attention_projection",
                     [](const std::vector<Var>& v) {
                       auto [el, er] = attention_projection(v[0], v[1], v[2]);
                       return concat({el, er});
                     },
                     {z, al, ar});
  }
  SECTION("edge softmax additive + aggregate (unfused)") {
    gradcheck::check("edge_softmax_additive+aggregate",
                     [g](const std::vector<Var>& v) {
                       auto [el, er] = attention_projection(v[0], v[1], v[2]);
                       return aggregate(g, edge_softmax_additive(g, el, er, 0.2f), v[0]);
                     },
                     {z, al, ar});
    // Logit sums el_i + er_j on both sides of LeakyReLU's kink but never near it.
    Tensor el = random_tensor(n, H, rng, 0.3f, 0.6f), er = random_tensor(n, H, rng, 0.0f, 0.1f);
    for (std::int64_t i = 0; i < n; i += 2)
      for (int k = 0; k < H; ++k) er.at(i, k) -= 1.5f;
    gradcheck::check("edge_softmax_additive",
                     [g](const std::vector<Var>& v) { return edge_softmax_additive(g, v[0], v[1], 0.2f); },
                     {el, er});
  }
  SECTION("edge softmax dot + aggregate") {
    gradcheck::check("edge_softmax_dot",
                     [g, H](const std::vector<Var>& v) { return edge_softmax_dot(g, v[0], H, 0.7f); }, {z});
    gradcheck::check("aggregate", [g](const std::vector<Var>& v) { return aggregate(g, v[0], v[1]); },
                     {random_tensor(g->num_edges(), H, rng, 0.f, 1.f), z});
  }
  SECTION("fused additive") {
    gradcheck::check("gat_additive",
                     [g](const std::vector<Var>& v) { return gat_additive(g, v[0], v[1], v[2], 0.2f); },
                     {z, al, ar});
  }
  SECTION("fused dot") {
    gradcheck::check("gat_dot", [g, H](const std::vector<Var>& v) { return gat_dot(g, v[0], H, 0.5f); }, {z});
  }
  SECTION("fused equals unfused") {
    NoGradGuard ng;
    Var zv(z), lv(al), rv(ar);
    Var fused = gat_additive(g, zv, lv, rv, 0.2f);
    auto [el, er] = attention_projection(zv, lv, rv);
    Var unfused = aggregate(g, edge_softmax_additive(g, el, er, 0.2f), zv);
    for (std::int64_t i = 0; i < n; ++i)
      for (std::int64_t c = 0; c < z.cols(); ++c)
        REQUIRE(fused.value().at(i, c) == Approx(unfused.value().at(i, c)).margin(1e-5));
    // The isolated node (last) aggregates nothing: zero, not NaN.
    for (std::int64_t c = 0; c < z.cols(); ++c) REQUIRE(fused.value().at(n - 1, c) == 0.0f);
  }
}

TEST_CASE("gradcheck pooling ops", "[autograd]") {
  auto rng = rng_for(3);
  CsrGraph a = fixtures::grid_graph(3, 2), b = fixtures::grid_graph(2, 2);
  GraphPtr g = share(batch_graphs({&a, &b}));
  SECTION("segment max + broadcast") {
    // Distinct values so the argmax is stable under the finite-difference step.
    Tensor x = Tensor::empty(g->num_nodes, 3);
    std::vector<float> vals;
    for (std::int64_t i = 0; i < x.numel(); ++i) vals.push_back(0.1f * float(i));
    std::shuffle(vals.begin(), vals.end(), rng);
    for (std::int64_t i = 0; i < x.numel(); ++i) x.at(i / 3, i % 3) = vals[i];
    gradcheck::check("segment_max", [g](const std::vector<Var>& v) { return segment_max(g, v[0]); }, {x});
    gradcheck::check("broadcast_segments",
                     [g](const std::vector<Var>& v) { return broadcast_segments(g, segment_max(g, v[0])); }, {x});
  }
  SECTION("linear_segment_bias, with the two row blocks of one weight") {
    // NeuroSkinning's classifier input: x ++ broadcast(g) times one weight,
    // split as x W[0:3] + broadcast(g W[3:5] + b). Checks the op's
    // gradients and that row-slice views of W accumulate into W's gradient.
    gradcheck::check("linear_segment_bias",
                     [g](const std::vector<Var>& v) {
                       Var s = linear(v[2], v[1].rows_slice(3, 5), v[3]);
                       return linear_segment_bias(g, v[0], v[1].rows_slice(0, 3), s);
                     },
                     {random_tensor(g->num_nodes, 3, rng), random_tensor(5, 4, rng),
                      random_tensor(g->num_segments(), 2, rng), random_tensor(1, 4, rng)});
  }
  SECTION("neighbour mean over a non-symmetric neighbour graph") {
    std::vector<std::vector<std::int32_t>> nb = {{0, 1, 2}, {1, 3}, {}, {0, 1, 2, 3}, {4, 0}};
    GraphPtr ng = share(graph_from_neighbour_lists(5, nb));
    gradcheck::check("neighbour_mean", [ng](const std::vector<Var>& v) { return neighbour_mean(ng, v[0]); },
                     {random_tensor(5, 4, rng)});
  }
}

namespace {
// A 3-layer multi-head GAT: Linear -> GAT(additive, H heads) -> tanh, three
// times, then a Linear head; returns the per-node prediction.
struct TinyGat {
  std::vector<Var> W, al, ar;
  Var head_W, head_b;
  TinyGat(std::mt19937& rng, int in, int H, int F) {
    int width = in;
    for (int l = 0; l < 3; ++l) {
      W.push_back(Var::parameter(random_tensor(width, H * F, rng, -0.5f, 0.5f), "W"));
      al.push_back(Var::parameter(random_tensor(H, F, rng), "a_l"));
      ar.push_back(Var::parameter(random_tensor(H, F, rng), "a_r"));
      width = H * F;
    }
    head_W = Var::parameter(random_tensor(width, 2, rng), "head_W");
    head_b = Var::parameter(random_tensor(1, 2, rng), "head_b");
  }
};
}  // namespace

TEST_CASE("gradcheck: 3-layer multi-head GAT end to end", "[autograd]") {
  auto rng = rng_for(4);
  GraphPtr g = small_mesh(0);
  const int H = 2, F = 3, in = 4;
  TinyGat net(rng, in, H, F);
  std::vector<Tensor> inputs = {random_tensor(g->num_nodes, in, rng)};
  std::vector<Var*> params;
  for (int l = 0; l < 3; ++l) {
    inputs.push_back(net.W[l].value());
    inputs.push_back(net.al[l].value());
    inputs.push_back(net.ar[l].value());
  }
  inputs.push_back(net.head_W.value());
  inputs.push_back(net.head_b.value());
  gradcheck::check("3-layer GAT",
                   [g](const std::vector<Var>& v) {
                     Var h = v[0];
                     for (int l = 0; l < 3; ++l)
                       h = tanh(gat_additive(g, linear(h, v[1 + 3 * l], Var{}), v[2 + 3 * l], v[3 + 3 * l]));
                     return linear(h, v[10], v[11]);
                   },
                   inputs);
}

TEST_CASE("dense buffer: blocks writing into slots give the gradients of an explicit concat", "[autograd]") {
  auto rng = rng_for(5);
  GraphPtr g = small_mesh(0);
  const std::int64_t n = g->num_nodes;
  Tensor x0 = random_tensor(n, 4, rng), W1 = random_tensor(4, 3, rng), W2 = random_tensor(7, 2, rng);
  auto run = [&](bool zero_copy, Tensor& gx, Tensor& gW1, Tensor& gW2) {
    Var x(x0.clone(), true), w1(W1.clone(), true), w2(W2.clone(), true);
    Var out;
    if (zero_copy) {
      Var buf(Tensor::empty(n, 9), false);
      copy_into(x, buf.cols_slice(0, 4));
      tanh(linear(buf.cols_slice(0, 4), w1, Var{}), buf.cols_slice(4, 7));
      tanh(linear(buf.cols_slice(0, 7), w2, Var{}), buf.cols_slice(7, 9));
      out = buf;
    } else {
      Var b1 = tanh(linear(x, w1, Var{}));
      Var b2 = tanh(linear(concat({x, b1}), w2, Var{}));
      out = concat({x, b1, b2});
    }
    Tensor R = Tensor::full(n, 9, 0.0f);
    for (std::int64_t i = 0; i < R.numel(); ++i) R.at(i / 9, i % 9) = std::sin(float(i));
    backward(sum(mul(out, Var(R))));
    gx = x.grad();
    gW1 = w1.grad();
    gW2 = w2.grad();
  };
  Tensor a[3], b[3];
  run(true, a[0], a[1], a[2]);
  run(false, b[0], b[1], b[2]);
  for (int k = 0; k < 3; ++k) {
    REQUIRE(a[k].defined());
    for (std::int64_t i = 0; i < a[k].numel(); ++i)
      REQUIRE(a[k].at(i / a[k].cols(), i % a[k].cols()) == Approx(b[k].at(i / b[k].cols(), i % b[k].cols())).margin(1e-5));
  }
}

TEST_CASE("linear_segment_bias on row slices gives the values and gradients of linear(concat(x, broadcast))",
          "[autograd]") {
  auto rng = rng_for(7);
  CsrGraph a = fixtures::grid_graph(3, 4), b = fixtures::grid_graph(2, 5), c = fixtures::grid_graph(4, 2);
  GraphPtr g = share(batch_graphs({&a, &b, &c}));
  const std::int64_t n = g->num_nodes, S = g->num_segments();
  Tensor x0 = random_tensor(n, 5, rng), g0 = random_tensor(S, 3, rng), W0 = random_tensor(8, 6, rng),
         b0 = random_tensor(1, 6, rng), R = random_tensor(n, 6, rng);
  auto run = [&](bool split, std::vector<Tensor>& out) {
    Var x(x0.clone(), true), gl(g0.clone(), true), W(W0.clone(), true), bias(b0.clone(), true);
    Var y = split ? linear_segment_bias(g, x, W.rows_slice(0, 5), linear(gl, W.rows_slice(5, 8), bias))
                  : linear(concat({x, broadcast_segments(g, gl)}), W, bias);
    backward(sum(mul(y, Var(R))));
    out = {y.value(), x.grad(), gl.grad(), W.grad(), bias.grad()};
  };
  std::vector<Tensor> s, r;
  run(true, s);
  run(false, r);
  for (std::size_t k = 0; k < s.size(); ++k) {
    INFO("output " << k);
    REQUIRE(s[k].defined());
    REQUIRE(s[k].same_shape(r[k]));
    for (std::int64_t i = 0; i < s[k].rows(); ++i)
      for (std::int64_t j = 0; j < s[k].cols(); ++j) REQUIRE(s[k].at(i, j) == Approx(r[k].at(i, j)).margin(1e-5));
  }
}

TEST_CASE("batch_norm_act(_linear) give the values, running statistics and gradients of the unfused ops",
          "[autograd]") {
  auto rng = rng_for(11);
  // 600 rows: more than one reduction block; x a column slice (strided).
  const Tensor wide = random_tensor(600, 30, rng, -2.f, 3.f);
  const Tensor gamma = random_tensor(1, 24, rng, -1.5f, 1.5f), beta = random_tensor(1, 24, rng);
  const Tensor W = random_tensor(24, 7, rng), b = random_tensor(1, 7, rng), R = random_tensor(600, 7, rng);
  for (Activation f : {Activation::leaky_relu, Activation::relu}) {
    INFO(activation_name(f));
    struct Run {
      Tensor out, dx, dg, db, dW, dbias;
      BatchNormState st;
    };
    auto run = [&](bool fuse, bool with_linear) {
      Run r;
      Var xw(wide.clone(), true), g(gamma.clone(), true), be(beta.clone(), true), w(W.clone(), true),
          bi(b.clone(), true);
      const Var x = xw.cols_slice(3, 27);
      Var out;
      if (with_linear)
        out = fuse ? batch_norm_act_linear(x, g, be, r.st, f, 0.1f, w, bi)
                   : linear(activation(f, batch_norm(x, g, be, r.st, true), 0.1f), w, bi);
      else
        out = fuse ? batch_norm_act(x, g, be, r.st, f, 0.1f) : activation(f, batch_norm(x, g, be, r.st, true), 0.1f);
      r.out = out.value().clone();
      backward(sum(mul(out, Var(with_linear ? R : wide.cols_slice(0, 24)))));
      r.dx = x.grad(), r.dg = g.grad(), r.db = be.grad();
      if (with_linear) r.dW = w.grad(), r.dbias = bi.grad();
      return r;
    };
    for (bool with_linear : {false, true}) {
      INFO("with_linear " << with_linear);
      const Run a = run(true, with_linear), e = run(false, with_linear);
      auto close = [](const Tensor& t, const Tensor& u, double tol) {
        REQUIRE(t.defined());
        REQUIRE(t.same_shape(u));
        for (std::int64_t i = 0; i < t.rows(); ++i)
          for (std::int64_t j = 0; j < t.cols(); ++j)
            REQUIRE(t.at(i, j) == Approx(u.at(i, j)).margin(tol * (1.0 + std::abs(u.at(i, j)))));
      };
      close(a.out, e.out, 1e-6);
      close(a.st.running_mean, e.st.running_mean, 0.0);
      close(a.st.running_var, e.st.running_var, 0.0);
      close(a.dx, e.dx, 1e-5);
      close(a.dg, e.dg, 1e-5);
      close(a.db, e.db, 1e-5);
      if (with_linear) close(a.dW, e.dW, 1e-5), close(a.dbias, e.dbias, 1e-6);
    }
  }
}

TEST_CASE("tape rules", "[autograd]") {
  auto rng = rng_for(6);
  SECTION("a saved tensor modified in place before backward is an error") {
    Var x(random_tensor(3, 3, rng), true);
    Var y = tanh(x);
    Var loss = sum(y);
    x.value().fill_(0.5f);  // in-place write bumps the version of x's storage
    REQUIRE_THROWS_MATCHES(backward(loss), AutogradError,
                           Catch::Matchers::Predicate<AutogradError>([](const AutogradError& e) {
                             std::string m = e.what();
                             return m.find("tanh") != std::string::npos && m.find("'x'") != std::string::npos &&
                                    m.find("modified in place") != std::string::npos;
                           }));
    REQUIRE(current_tape().size() == 0);  // cleared even on error
  }
  SECTION("no-grad scope records nothing") {
    Var x(random_tensor(3, 3, rng), true);
    {
      NoGradGuard ng;
      Var y = tanh(linear(x, x, Var{}));
      REQUIRE_FALSE(y.requires_grad());
    }
    REQUIRE(current_tape().size() == 0);
  }
  SECTION("backward clears the tape; gradients accumulate across backward calls") {
    Var x(random_tensor(2, 2, rng), true);
    backward(sum(x));
    REQUIRE(current_tape().size() == 0);
    backward(sum(x));
    REQUIRE(x.grad().at(0, 0) == Approx(2.0f));
    x.zero_grad();
    REQUIRE_FALSE(x.grad().defined());
  }
  SECTION("backward needs a scalar that requires grad") {
    Var x(random_tensor(2, 2, rng), true);
    REQUIRE_THROWS_WITH(backward(tanh(x)), Catch::Contains("[1, 1]"));
    current_tape().clear();
    REQUIRE_THROWS_WITH(backward(sum(Var(random_tensor(2, 2, rng)))), Catch::Contains("does not require grad"));
  }
}

TEST_CASE("op argument errors name the problem", "[autograd][errors]") {
  auto rng = rng_for(7);
  GraphPtr g = small_mesh(0);
  Var z(random_tensor(g->num_nodes, 6, rng));
  REQUIRE_THROWS_WITH(linear(z, Var(random_tensor(5, 2, rng)), Var{}), Catch::Contains("x.cols must equal W.rows"));
  REQUIRE_THROWS_WITH(gat_additive(g, Var(random_tensor(3, 6, rng)), Var(random_tensor(2, 3, rng)),
                                   Var(random_tensor(2, 3, rng))),
                      Catch::Contains("graph has"));
  REQUIRE_THROWS_WITH(gat_dot(g, z, 4), Catch::Contains("do not split into 4 heads"));
  REQUIRE_THROWS_WITH(add(z, Var(random_tensor(2, 2, rng))), Catch::Contains("same shape"));
  REQUIRE_THROWS_WITH(mse_loss(z, Tensor::zeros(1, 1)), Catch::Contains("same shape"));
  REQUIRE_THROWS_WITH(gat_additive(nullptr, z, z, z), Catch::Contains("graph is null"));
}
