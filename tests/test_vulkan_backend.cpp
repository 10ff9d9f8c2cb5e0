// Every Backend entry implemented on Vulkan against the CPU backend on random
// data and random graphs (isolated nodes, a high-degree row, a batch),
// forward and backward, accumulating outputs seeded with random values.
// ctest runs it again with GATCORE_VK_MAX_BINDING_BYTES=256 at every
// LP_NATIVE_VECTOR_WIDTH (*_smallbind): then the same comparisons cover the
// large-operand paths (row-chunked elementwise ops, device-address shaders).
#include <limits>
#include <random>

#include "gatcore/graph.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using vkt::H;
using vkt::require_close;
using vkt::V;

namespace {

Backend& cpu() { return backend(Device::cpu); }
Backend& gpu() { return backend(Device::vulkan); }

Tensor rnd(std::int64_t r, std::int64_t c, std::mt19937& rng, float lo = -1.f, float hi = 1.f) {
  return gradcheck::random_tensor(r, c, rng, lo, hi);
}

// Graphs: a grid with isolated vertices, a hub row (degree n-1) and a batch.
std::vector<CsrGraph> test_graphs() {
  std::vector<CsrGraph> gs;
  gs.push_back(fixtures::grid_graph(7, 5, 3));
  std::vector<std::int32_t> src, dst;
  const int n = 90;
  for (int j = 1; j < n; ++j) {
    src.push_back(j);
    dst.push_back(0);
  }
  for (int j = 1; j + 1 < n; j += 3) {
    src.push_back(j);
    dst.push_back(j + 1);
  }
  gs.push_back(graph_from_edges(n, src, dst));
  CsrGraph a = fixtures::grid_graph(4, 3, 1), b = fixtures::grid_graph(5, 5, 0);
  gs.push_back(batch_graphs({&a, &b}));
  return gs;
}

}  // namespace

TEST_CASE("vulkan: elementwise, activations, bias, column sums, scalars", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(1);
  const std::int64_t n = 37, c = 13;
  Tensor a = rnd(n, c, rng), b = rnd(n, c, rng), y0 = rnd(n, c, rng);
  // Strided views: a column slice of a wider buffer.
  Tensor wide = rnd(n, c + 5, rng);
  Tensor view = wide.cols_slice(2, 2 + c);

  SECTION("fill / copy / axpby / axpy / mul / mul_accumulate") {
    Tensor yc = y0.clone(), yg = V(y0);
    cpu().fill(yc, 2.5f);
    gpu().fill(yg, 2.5f);
    require_close(yc, yg);
    Tensor wg = V(wide);
    cpu().copy(a, view);
    gpu().copy(V(a), wg.cols_slice(2, 2 + c));
    require_close(wide, wg, 0, 0, "copy into a view");
    cpu().axpby(0.5f, a, -2.f, b, yc);
    gpu().axpby(0.5f, V(a), -2.f, V(b), yg);
    require_close(yc, yg, 1e-6f, 1e-6f, "axpby");
    cpu().axpy(0.75f, a, yc);
    gpu().axpy(0.75f, V(a), yg);
    require_close(yc, yg, 1e-6f, 1e-6f, "axpy");
    cpu().mul(a, b, yc);
    gpu().mul(V(a), V(b), yg);
    require_close(yc, yg, 1e-6f, 1e-6f, "mul");
    cpu().mul_accumulate(a, b, yc);
    gpu().mul_accumulate(V(a), V(b), yg);
    require_close(yc, yg, 1e-6f, 1e-6f, "mul_accumulate");
  }
  SECTION("activations forward and backward") {
    Tensor x = rnd(n, c, rng, -4.f, 4.f);
    for (Activation f : {Activation::identity, Activation::tanh, Activation::tanhshrink, Activation::leaky_relu,
                         Activation::relu}) {
      INFO(activation_name(f));
      Tensor yc = Tensor::empty(n, c), yg = gpu().empty(n, c, DType::f32);
      cpu().activation_forward(f, x, yc, 0.1f);
      gpu().activation_forward(f, V(x), yg, 0.1f);
      require_close(yc, yg, 1e-5f, 1e-6f, "forward");
      Tensor dc = y0.clone(), dg = V(y0);
      cpu().activation_backward(f, x, yc, b, dc, 0.1f, true);
      gpu().activation_backward(f, V(x), yg, V(b), dg, 0.1f, true);
      require_close(dc, dg, 1e-5f, 1e-5f, "backward from x and y");
      if (f != Activation::tanhshrink) {
        cpu().activation_backward(f, Tensor(), yc, b, dc, 0.1f, true);
        gpu().activation_backward(f, Tensor(), yg, V(b), dg, 0.1f, true);
        require_close(dc, dg, 1e-5f, 1e-5f, "backward from y");
      }
      // Written, not accumulated: what was in d_x (NaN here) is ignored.
      Tensor nan = Tensor::full(n, c, std::numeric_limits<float>::quiet_NaN());
      Tensor dc0 = nan.clone(), dg0 = V(nan);
      cpu().activation_backward(f, x, yc, b, dc0, 0.1f, false);
      gpu().activation_backward(f, V(x), yg, V(b), dg0, 0.1f, false);
      require_close(dc0, dg0, 1e-5f, 1e-5f, "backward written");
    }
  }
  SECTION("bias, column sums, sum, scalar broadcast") {
    Tensor bias = rnd(1, c, rng);
    Tensor yc = y0.clone(), yg = V(y0);
    cpu().add_row_bias(bias, yc);
    gpu().add_row_bias(V(bias), yg);
    require_close(yc, yg, 1e-6f, 1e-6f, "add_row_bias");
    Tensor dbc = bias.clone(), dbg = V(bias);
    cpu().column_sums_accumulate(view, dbc);
    gpu().column_sums_accumulate(V(wide).cols_slice(2, 2 + c), dbg);
    require_close(dbc, dbg, 1e-5f, 1e-5f, "column_sums_accumulate");
    Tensor sc = Tensor::empty(1, 1), sg = gpu().empty(1, 1, DType::f32);
    cpu().sum_all(a, sc);
    gpu().sum_all(V(a), sg);
    require_close(sc, sg, 1e-5f, 1e-5f, "sum_all");
    cpu().add_scalar_accumulate(sc, -0.5f, yc);
    gpu().add_scalar_accumulate(sg, -0.5f, yg);
    require_close(yc, yg, 1e-5f, 1e-5f, "add_scalar_accumulate");
  }
  large_paths.require();
}

TEST_CASE("vulkan: gemm, all transpose combinations and strided views", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(2);
  for (auto [M, N, K] : {std::array<int, 3>{1, 1, 1}, {70, 33, 129}, {5, 130, 17}}) {
    for (int ta = 0; ta < 2; ++ta)
      for (int tb = 0; tb < 2; ++tb) {
        INFO("M " << M << " N " << N << " K " << K << " ta " << ta << " tb " << tb);
        Tensor A = ta ? rnd(K, M, rng) : rnd(M, K, rng);
        Tensor Bw = tb ? rnd(N, K + 3, rng) : rnd(K, N + 3, rng);
        Tensor B = tb ? Bw.cols_slice(3, K + 3) : Bw.cols_slice(3, N + 3);
        Tensor C = rnd(M, N, rng);
        for (float beta : {0.f, 1.f, 0.5f}) {
          Tensor Cc = C.clone(), Cg = V(C);
          cpu().gemm(A, ta, B, tb, Cc, 1.5f, beta);
          gpu().gemm(V(A), ta, V(Bw).cols_slice(3, tb ? K + 3 : N + 3), tb, Cg, 1.5f, beta);
          require_close(Cc, Cg, 1e-4f, 1e-4f, "gemm");
        }
      }
  }
  large_paths.require();
}

TEST_CASE("vulkan: row softmax, losses, adam", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(3);
  const std::int64_t n = 29, c = 11;
  Tensor x = rnd(n, c, rng, -3.f, 3.f), d = rnd(n, c, rng), g0 = rnd(n, c, rng);
  Tensor mask = Tensor::full(1, c, 1.f);
  mask.at(0, 3) = 0.f;
  mask.at(0, 7) = 0.f;
  for (bool masked : {false, true}) {
    Tensor m = masked ? mask : Tensor();
    Tensor yc = Tensor::empty(n, c), yg = gpu().empty(n, c, DType::f32);
    cpu().row_softmax_forward(x, m, yc);
    gpu().row_softmax_forward(V(x), masked ? V(mask) : Tensor(), yg);
    require_close(yc, yg, 1e-5f, 1e-6f, "row_softmax_forward");
    Tensor dc = g0.clone(), dg = V(g0);
    cpu().row_softmax_backward(yc, d, dc);
    gpu().row_softmax_backward(yg, V(d), dg);
    require_close(dc, dg, 1e-5f, 1e-5f, "row_softmax_backward");
  }
  Tensor p = rnd(n, c, rng, 0.f, 1.f), t = rnd(n, c, rng, 0.f, 1.f);
  t.at(0, 0) = 0.f;
  p.at(1, 1) = 0.f;
  Tensor lc = Tensor::empty(1, 1), lg = gpu().empty(1, 1, DType::f32);
  Tensor dout = Tensor::full(1, 1, 0.7f);
  cpu().mse_forward(p, t, lc);
  gpu().mse_forward(V(p), V(t), lg);
  require_close(lc, lg, 1e-5f, 1e-6f, "mse_forward");
  Tensor dc = g0.clone(), dg = V(g0);
  cpu().mse_backward(p, t, dout, dc);
  gpu().mse_backward(V(p), V(t), V(dout), dg);
  require_close(dc, dg, 1e-5f, 1e-6f, "mse_backward");
  cpu().kl_div_forward(p, t, 1e-6f, lc);
  gpu().kl_div_forward(V(p), V(t), 1e-6f, lg);
  require_close(lc, lg, 1e-4f, 1e-5f, "kl_div_forward");
  cpu().kl_div_backward(p, t, 1e-6f, dout, dc);
  gpu().kl_div_backward(V(p), V(t), 1e-6f, V(dout), dg);
  require_close(dc, dg, 1e-5f, 1e-3f, "kl_div_backward");

  Tensor P = rnd(n, c, rng), G = rnd(n, c, rng), M = rnd(n, c, rng, 0.f, .1f), Vv = rnd(n, c, rng, 0.f, .1f);
  Tensor Pg = V(P), Mg = V(M), Vg = V(Vv);
  for (long step = 1; step <= 3; ++step) {
    cpu().adam_update(P, G, M, Vv, 1e-2f, 0.9f, 0.999f, 1e-8f, 0.01f, step);
    gpu().adam_update(Pg, V(G), Mg, Vg, 1e-2f, 0.9f, 0.999f, 1e-8f, 0.01f, step);
  }
  require_close(P, Pg, 1e-5f, 1e-6f, "adam param");
  require_close(M, Mg, 1e-5f, 1e-6f, "adam m");
  require_close(Vv, Vg, 1e-5f, 1e-7f, "adam v");
  large_paths.require();
}

TEST_CASE("vulkan: attention projection, edge softmax, aggregation, fused GAT", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(4);
  const auto graphs = test_graphs();
  for (std::size_t gi = 0; gi < graphs.size(); ++gi) {
    const CsrGraph& g = graphs[gi];
    const std::int64_t n = g.num_nodes, E = g.num_edges();
    for (auto [Hh, F] : {std::array<int, 2>{1, 5}, {3, 8}, {2, 37}}) {
      INFO("graph " << gi << " heads " << Hh << " F " << F);
      const int C = Hh * F;
      Tensor z = rnd(n, C, rng), al = rnd(Hh, F, rng), ar = rnd(Hh, F, rng);
      // projection
      Tensor elc = Tensor::empty(n, Hh), erc = Tensor::empty(n, Hh);
      Tensor elg = gpu().empty(n, Hh, DType::f32), erg = gpu().empty(n, Hh, DType::f32);
      cpu().attention_projection_forward(z, al, ar, elc, erc);
      gpu().attention_projection_forward(V(z), V(al), V(ar), elg, erg);
      require_close(elc, elg, 1e-4f, 1e-5f, "projection el");
      require_close(erc, erg, 1e-4f, 1e-5f, "projection er");
      Tensor del = rnd(n, Hh, rng), der = rnd(n, Hh, rng), dz0 = rnd(n, C, rng), da0 = rnd(Hh, F, rng);
      {
        Tensor dzc = dz0.clone(), dalc = da0.clone(), darc = da0.clone();
        Tensor dzg = V(dz0), dalg = V(da0), darg = V(da0);
        cpu().attention_projection_backward(z, al, ar, del, der, dzc, dalc, darc);
        gpu().attention_projection_backward(V(z), V(al), V(ar), V(del), V(der), dzg, dalg, darg);
        require_close(dzc, dzg, 1e-4f, 1e-5f, "projection d_z");
        require_close(dalc, dalg, 1e-4f, 1e-4f, "projection d_al");
        require_close(darc, darg, 1e-4f, 1e-4f, "projection d_ar");
      }
      // additive edge softmax
      Tensor ac = Tensor::empty(E, Hh), ag = gpu().empty(E, Hh, DType::f32);
      cpu().edge_softmax_additive_forward(g, elc, erc, 0.2f, ac);
      gpu().edge_softmax_additive_forward(g, V(elc), V(erc), 0.2f, ag);
      require_close(ac, ag, 1e-4f, 1e-6f, "edge_softmax_additive_forward");
      Tensor dalpha = rnd(E, Hh, rng);
      {
        Tensor delc = del.clone(), derc = der.clone(), delg = V(del), derg = V(der);
        cpu().edge_softmax_additive_backward(g, elc, erc, 0.2f, ac, dalpha, delc, derc);
        gpu().edge_softmax_additive_backward(g, V(elc), V(erc), 0.2f, V(ac), V(dalpha), delg, derg);
        require_close(delc, delg, 1e-4f, 1e-5f, "edge_softmax_additive_backward d_el");
        require_close(derc, derg, 1e-4f, 1e-5f, "edge_softmax_additive_backward d_er");
      }
      // dot edge softmax
      const float scale = 1.0f / std::sqrt(static_cast<float>(F));
      Tensor dc = Tensor::empty(E, Hh), dg = gpu().empty(E, Hh, DType::f32);
      cpu().edge_softmax_dot_forward(g, z, Hh, scale, dc);
      gpu().edge_softmax_dot_forward(g, V(z), Hh, scale, dg);
      require_close(dc, dg, 1e-4f, 1e-6f, "edge_softmax_dot_forward");
      {
        Tensor dhc = dz0.clone(), dhg = V(dz0);
        cpu().edge_softmax_dot_backward(g, z, Hh, scale, dc, dalpha, dhc);
        gpu().edge_softmax_dot_backward(g, V(z), Hh, scale, V(dc), V(dalpha), dhg);
        require_close(dhc, dhg, 1e-4f, 1e-5f, "edge_softmax_dot_backward");
      }
      // aggregation
      Tensor oc = Tensor::empty(n, C), og = gpu().empty(n, C, DType::f32);
      cpu().aggregate_forward(g, ac, z, oc);
      gpu().aggregate_forward(g, V(ac), V(z), og);
      require_close(oc, og, 1e-4f, 1e-5f, "aggregate_forward");
      Tensor dout = rnd(n, C, rng);
      {
        Tensor dac = Tensor::empty(E, Hh), dag = gpu().empty(E, Hh, DType::f32);
        Tensor dzc = dz0.clone(), dzg = V(dz0);
        cpu().aggregate_backward(g, ac, z, dout, dac, dzc);
        gpu().aggregate_backward(g, V(ac), V(z), V(dout), dag, dzg);
        require_close(dac, dag, 1e-4f, 1e-5f, "aggregate_backward d_alpha");
        require_close(dzc, dzg, 1e-4f, 1e-5f, "aggregate_backward d_z");
      }
      // fused
      {
        Tensor fo = Tensor::empty(n, C), fa = Tensor::empty(E, Hh);
        Tensor fog = gpu().empty(n, C, DType::f32), fag = gpu().empty(E, Hh, DType::f32);
        cpu().gat_fused_additive_forward(g, z, elc, erc, 0.2f, fo, fa);
        gpu().gat_fused_additive_forward(g, V(z), V(elc), V(erc), 0.2f, fog, fag);
        require_close(fo, fog, 1e-4f, 1e-5f, "gat_fused_additive_forward out");
        require_close(fa, fag, 1e-4f, 1e-6f, "gat_fused_additive_forward alpha");
        Tensor dzc = dz0.clone(), delc = del.clone(), derc = der.clone();
        Tensor dzg = V(dz0), delg = V(del), derg = V(der);
        cpu().gat_fused_additive_backward(g, z, elc, erc, 0.2f, fa, dout, dzc, delc, derc);
        gpu().gat_fused_additive_backward(g, V(z), V(elc), V(erc), 0.2f, V(fa), V(dout), dzg, delg, derg);
        require_close(dzc, dzg, 1e-4f, 1e-4f, "gat_fused_additive_backward d_z");
        require_close(delc, delg, 1e-4f, 1e-4f, "gat_fused_additive_backward d_el");
        require_close(derc, derg, 1e-4f, 1e-4f, "gat_fused_additive_backward d_er");
      }
      {
        Tensor fo = Tensor::empty(n, C), fa = Tensor::empty(E, Hh);
        Tensor fog = gpu().empty(n, C, DType::f32), fag = gpu().empty(E, Hh, DType::f32);
        cpu().gat_fused_dot_forward(g, z, Hh, scale, fo, fa);
        gpu().gat_fused_dot_forward(g, V(z), Hh, scale, fog, fag);
        require_close(fo, fog, 1e-4f, 1e-5f, "gat_fused_dot_forward out");
        require_close(fa, fag, 1e-4f, 1e-6f, "gat_fused_dot_forward alpha");
        Tensor dzc = dz0.clone(), dzg = V(dz0);
        cpu().gat_fused_dot_backward(g, z, Hh, scale, fa, dout, dzc);
        gpu().gat_fused_dot_backward(g, V(z), Hh, scale, V(fa), V(dout), dzg);
        require_close(dzc, dzg, 1e-4f, 1e-4f, "gat_fused_dot_backward d_z");
      }
    }
  }
  large_paths.require();
}

TEST_CASE("vulkan: batchnorm train / eval forward and backward", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(6);
  const std::int64_t n = 300, c = 7;
  Tensor x = rnd(n, c, rng, -2.f, 3.f), gamma = rnd(1, c, rng, .5f, 1.5f), beta = rnd(1, c, rng);
  Tensor rm = rnd(1, c, rng), rv = rnd(1, c, rng, .5f, 2.f), dy = rnd(n, c, rng), dx0 = rnd(n, c, rng);
  Tensor yc = Tensor::empty(n, c), smc = Tensor::empty(1, c), sic = Tensor::empty(1, c), rmc = rm.clone(),
         rvc = rv.clone();
  Tensor yg = gpu().empty(n, c, DType::f32), smg = gpu().empty(1, c, DType::f32), sig = gpu().empty(1, c, DType::f32);
  Tensor rmg = V(rm), rvg = V(rv);
  cpu().batchnorm_train_forward(x, gamma, beta, 1e-5f, 0.1f, yc, smc, sic, rmc, rvc);
  gpu().batchnorm_train_forward(V(x), V(gamma), V(beta), 1e-5f, 0.1f, yg, smg, sig, rmg, rvg);
  require_close(yc, yg, 1e-4f, 1e-4f, "train y");
  require_close(smc, smg, 1e-4f, 1e-5f, "save_mean");
  require_close(sic, sig, 1e-4f, 1e-5f, "save_invstd");
  require_close(rmc, rmg, 1e-4f, 1e-5f, "running_mean");
  require_close(rvc, rvg, 1e-4f, 1e-5f, "running_var");
  Tensor dxc = dx0.clone(), dgc = gamma.clone(), dbc = beta.clone(), dxg = V(dx0), dgg = V(gamma), dbg = V(beta);
  cpu().batchnorm_train_backward(x, gamma, smc, sic, dy, dxc, dgc, dbc, true);
  gpu().batchnorm_train_backward(V(x), V(gamma), smg, sig, V(dy), dxg, dgg, dbg, true);
  require_close(dxc, dxg, 1e-4f, 1e-4f, "train d_x");
  {  // d_x written, not accumulated: its NaN contents are ignored
    Tensor nan = Tensor::full(n, c, std::numeric_limits<float>::quiet_NaN());
    Tensor dxc0 = nan.clone(), dxg0 = V(nan);
    cpu().batchnorm_train_backward(x, gamma, smc, sic, dy, dxc0, Tensor(), Tensor(), false);
    gpu().batchnorm_train_backward(V(x), V(gamma), smg, sig, V(dy), dxg0, Tensor(), Tensor(), false);
    require_close(dxc0, dxg0, 1e-4f, 1e-4f, "train d_x written");
  }
  require_close(dgc, dgg, 1e-4f, 1e-4f, "train d_gamma");
  require_close(dbc, dbg, 1e-4f, 1e-4f, "train d_beta");
  cpu().batchnorm_eval_forward(x, gamma, Tensor(), rm, rv, 1e-5f, yc);
  gpu().batchnorm_eval_forward(V(x), V(gamma), Tensor(), V(rm), V(rv), 1e-5f, yg);
  require_close(yc, yg, 1e-4f, 1e-4f, "eval y");
  cpu().batchnorm_eval_backward(x, Tensor(), rm, rv, 1e-5f, dy, dxc, dgc, dbc);
  gpu().batchnorm_eval_backward(V(x), Tensor(), V(rm), V(rv), 1e-5f, V(dy), dxg, dgg, dbg);
  require_close(dxc, dxg, 1e-4f, 1e-4f, "eval d_x");
  require_close(dgc, dgg, 1e-4f, 1e-4f, "eval d_gamma");
  require_close(dbc, dbg, 1e-4f, 1e-4f, "eval d_beta");
  large_paths.require();
}

TEST_CASE("vulkan: batchnorm fused with an activation (the Backend's composition of the unfused kernels)",
          "[vulkan]") {
  if (!vkt::ready()) return;
  std::mt19937 rng(16);
  const std::int64_t n = 300, c = 7;
  Tensor x = rnd(n, c, rng, -2.f, 3.f), gamma = rnd(1, c, rng, -1.5f, 1.5f), beta = rnd(1, c, rng);
  Tensor rm = rnd(1, c, rng), rv = rnd(1, c, rng, .5f, 2.f), dy = rnd(n, c, rng), dx0 = rnd(n, c, rng);
  for (Activation f : {Activation::leaky_relu, Activation::relu}) {
    INFO(activation_name(f));
    Tensor yc = Tensor::empty(n, c), smc = Tensor::empty(1, c), sic = Tensor::empty(1, c), afc = Tensor::empty(2, c);
    Tensor rmc = rm.clone(), rvc = rv.clone();
    Tensor yg = gpu().empty(n, c, DType::f32), smg = gpu().empty(1, c, DType::f32), sig = gpu().empty(1, c, DType::f32);
    Tensor afg = gpu().empty(2, c, DType::f32), rmg = V(rm), rvg = V(rv);
    cpu().batchnorm_act_train_forward(x, gamma, beta, 1e-5f, 0.1f, f, 0.1f, yc, smc, sic, afc, rmc, rvc, {});
    gpu().batchnorm_act_train_forward(V(x), V(gamma), V(beta), 1e-5f, 0.1f, f, 0.1f, yg, smg, sig, afg, rmg, rvg, {});
    require_close(yc, yg, 1e-4f, 1e-4f, "y");
    require_close(smc, smg, 1e-4f, 1e-5f, "save_mean");
    require_close(sic, sig, 1e-4f, 1e-5f, "save_invstd");
    require_close(rmc, rmg, 1e-4f, 1e-5f, "running_mean");
    require_close(rvc, rvg, 1e-4f, 1e-5f, "running_var");
    Tensor yg2 = gpu().empty(n, c, DType::f32);
    gpu().batchnorm_act_apply(V(x), V(gamma), V(beta), 1e-5f, f, 0.1f, smg, afg, yg2);
    require_close(yc, yg2, 1e-4f, 1e-4f, "apply y");
    Tensor dxc = dx0.clone(), dgc = gamma.clone(), dbc = beta.clone(), dxg = V(dx0), dgg = V(gamma), dbg = V(beta);
    cpu().batchnorm_act_train_backward(x, gamma, beta, 1e-5f, f, 0.1f, smc, sic, afc, dy, dxc, dgc, dbc, {}, true);
    gpu().batchnorm_act_train_backward(V(x), V(gamma), V(beta), 1e-5f, f, 0.1f, smg, sig, afg, V(dy), dxg, dgg, dbg,
                                       {}, true);
    require_close(dxc, dxg, 1e-4f, 1e-4f, "d_x");
    Tensor nan = Tensor::full(n, c, std::numeric_limits<float>::quiet_NaN());
    Tensor dxc0 = nan.clone(), dxg0 = V(nan);
    cpu().batchnorm_act_train_backward(x, gamma, beta, 1e-5f, f, 0.1f, smc, sic, afc, dy, dxc0, Tensor(), Tensor(),
                                       {}, false);
    gpu().batchnorm_act_train_backward(V(x), V(gamma), V(beta), 1e-5f, f, 0.1f, smg, sig, afg, V(dy), dxg0,
                                       Tensor(), Tensor(), {}, false);
    require_close(dxc0, dxg0, 1e-4f, 1e-4f, "d_x written");
    require_close(dgc, dgg, 1e-4f, 1e-4f, "d_gamma");
    require_close(dbc, dbg, 1e-4f, 1e-4f, "d_beta");
  }
}

TEST_CASE("vulkan: pooling (segment max, broadcast, neighbour mean)", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(8);
  const std::int64_t n = 61, C = 9;
  Tensor x = rnd(n, C, rng);
  x.at(5, 2) = x.at(6, 2);  // a tie: the first maximum wins
  // Segments with an empty one in the middle.
  const std::vector<std::int64_t> seg = {0, 20, 20, 45, 61};
  const std::int64_t S = 4;
  Tensor oc = Tensor::empty(S, C), ac = Tensor::empty(S, C, DType::i32);
  Tensor og = gpu().empty(S, C, DType::f32), ag = gpu().empty(S, C, DType::i32);
  cpu().segment_max_forward(x, seg, oc, ac);
  gpu().segment_max_forward(V(x), seg, og, ag);
  require_close(oc, og, 0, 0, "segment_max out");
  Tensor ah = H(ag);
  for (std::int64_t s = 0; s < S; ++s)
    for (std::int64_t c = 0; c < C; ++c) REQUIRE(ah.at_i32(s, c) == ac.at_i32(s, c));
  Tensor dS = rnd(S, C, rng), dx0 = rnd(n, C, rng);
  Tensor dxc = dx0.clone(), dxg = V(dx0);
  cpu().segment_max_backward(dS, ac, dxc);
  gpu().segment_max_backward(V(dS), ag, dxg);
  require_close(dxc, dxg, 1e-6f, 1e-6f, "segment_max_backward");
  Tensor bc = Tensor::empty(n, C), bg = gpu().empty(n, C, DType::f32);
  cpu().broadcast_segments_forward(oc, seg, bc);
  gpu().broadcast_segments_forward(og, seg, bg);
  require_close(bc, bg, 0, 0, "broadcast_segments_forward");
  Tensor dSc = dS.clone(), dSg = V(dS);
  cpu().broadcast_segments_backward(dx0, seg, dSc);
  gpu().broadcast_segments_backward(V(dx0), seg, dSg);
  require_close(dSc, dSg, 1e-5f, 1e-5f, "broadcast_segments_backward");
  // Neighbour lists: uneven sizes, an empty one, a node listed by many.
  std::vector<std::vector<std::int32_t>> nb(static_cast<std::size_t>(n));
  for (std::int32_t i = 0; i < n; ++i)
    for (std::int32_t k = 0; k < i % 5; ++k) nb[i].push_back((i * 7 + k * 13) % n);
  for (std::int32_t i = 0; i < n; i += 2) nb[i].push_back(3);
  const CsrGraph g = graph_from_neighbour_lists(n, nb);
  Tensor mc = Tensor::empty(n, C), mg = gpu().empty(n, C, DType::f32);
  cpu().neighbour_mean_forward(g, x, mc);
  gpu().neighbour_mean_forward(g, V(x), mg);
  require_close(mc, mg, 1e-5f, 1e-6f, "neighbour_mean_forward");
  dxc = dx0.clone();
  dxg = V(dx0);
  Tensor d = rnd(n, C, rng);
  cpu().neighbour_mean_backward(g, d, dxc);
  gpu().neighbour_mean_backward(g, V(d), dxg);
  require_close(dxc, dxg, 1e-5f, 1e-5f, "neighbour_mean_backward");
  REQUIRE_THROWS_WITH(gpu().broadcast_segments_forward(og, std::vector<std::int64_t>{0, 5}, bg),
                      Catch::Contains("seg_ptr"));
  large_paths.require();
}

// lavapipe ends an invocation's loops after 65535 iterations in total; the
// per-invocation edge and segment loops take 16 steps per iteration
// (STRIDED_FOR), so a hub row of 70000 in-edges, walked up to three times,
// still comes out whole.
TEST_CASE("vulkan: a hub row past lavapipe's loop cap", "[vulkan]") {
  if (!vkt::ready()) return;
  const vkt::LargePaths large_paths;
  std::mt19937 rng(6);
  const std::int32_t hub = 70000, n = hub + 1;
  std::vector<std::int32_t> src, dst;
  for (std::int32_t j = 1; j < n; ++j) {
    src.push_back(j);
    dst.push_back(0);
  }
  const CsrGraph g = graph_from_edges(n, src, dst);
  const std::int64_t E = g.num_edges(), Hh = 2, C = 4;
  Tensor el = rnd(n, Hh, rng), er = rnd(n, Hh, rng), z = rnd(n, C, rng);
  Tensor ac = Tensor::empty(E, Hh), ag = gpu().empty(E, Hh, DType::f32);
  cpu().edge_softmax_additive_forward(g, el, er, 0.2f, ac);
  gpu().edge_softmax_additive_forward(g, V(el), V(er), 0.2f, ag);
  require_close(ac, ag, 1e-4f, 1e-7f, "edge_softmax_additive_forward");
  Tensor oc = Tensor::empty(n, C), og = gpu().empty(n, C, DType::f32);
  cpu().aggregate_forward(g, ac, z, oc);
  gpu().aggregate_forward(g, ag, V(z), og);
  require_close(oc, og, 1e-4f, 1e-6f, "aggregate_forward");
  Tensor mc = Tensor::empty(n, C), mg = gpu().empty(n, C, DType::f32);
  cpu().neighbour_mean_forward(g, z, mc);
  gpu().neighbour_mean_forward(g, V(z), mg);
  require_close(mc, mg, 1e-4f, 1e-6f, "neighbour_mean_forward");
  // One segment of all n rows.
  const std::vector<std::int64_t> seg = {0, n};
  Tensor sc = Tensor::empty(1, C), sa = Tensor::empty(1, C, DType::i32);
  Tensor sg = gpu().empty(1, C, DType::f32), sag = gpu().empty(1, C, DType::i32);
  cpu().segment_max_forward(z, seg, sc, sa);
  gpu().segment_max_forward(V(z), seg, sg, sag);
  require_close(sc, sg, 0, 0, "segment_max_forward");
  Tensor dxc = Tensor::zeros(1, C), dxg = gpu().zeros(1, C, DType::f32);
  cpu().broadcast_segments_backward(z, seg, dxc);
  gpu().broadcast_segments_backward(V(z), seg, dxg);
  require_close(dxc, dxg, 1e-4f, 1e-3f, "broadcast_segments_backward");
  large_paths.require();
}
