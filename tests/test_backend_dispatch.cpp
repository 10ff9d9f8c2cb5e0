// Ops dispatch on the device their tensors live on. A fake "vulkan" backend
// (host-visible memory tagged as the other device, forwarding every kernel to
// the CPU backend and counting calls) checks that a whole forward + backward
// goes through the backend of the tensors' device, gives the CPU's results,
// and that mixing devices is an error.
#include <catch2/catch.hpp>

#include "gatcore/backend.hpp"
#include "gatcore/ops.hpp"
#include "gradcheck.hpp"
#include "mesh_fixtures.hpp"

using namespace gatcore;

namespace {

class FakeDeviceBackend final : public Backend {
 public:
  long calls = 0;
  Device device() const override { return Device::vulkan; }
  static Backend& cpu() { return backend(Device::cpu); }
  // A CPU-tagged alias of a fake-device tensor, for the CPU kernels.
  static Tensor host_alias(const Tensor& t) {
    if (!t.defined() || t.device() == Device::cpu) return t;
    auto orig = t.storage();
    std::shared_ptr<Storage> alias(new Storage, [orig](Storage* s) { delete s; });
    alias->host = orig->host;
    alias->bytes = orig->bytes;
    return Tensor::wrap(alias, t.dtype(), t.offset(), t.rows(), t.cols(), t.ld());
  }
  static Tensor retag(Tensor t) {
    t.storage()->device = Device::vulkan;
    return t;
  }
  Tensor empty(std::int64_t r, std::int64_t c, DType dt) override { return retag(Tensor::empty(r, c, dt)); }
  Tensor zeros(std::int64_t r, std::int64_t c, DType dt) override { return retag(Tensor::zeros(r, c, dt)); }
  Tensor from_host(const Tensor& t) override { return retag(t.clone()); }
  Tensor to_host(const Tensor& t) override { return host_alias(t).clone(); }
  void fill(const Tensor& y, float value) override {
    ++calls;
    cpu().fill(host_alias(y), value);
  }
  void copy(const Tensor& src, const Tensor& dst) override {
    ++calls;
    cpu().copy(host_alias(src), host_alias(dst));
  }
  void gemm(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha, float beta) override {
    ++calls;
    cpu().gemm(host_alias(A), trans_a, host_alias(B), trans_b, host_alias(C), alpha, beta);
  }
  void add_row_bias(const Tensor& bias, const Tensor& y) override {
    ++calls;
    cpu().add_row_bias(host_alias(bias), host_alias(y));
  }
  void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias) override {
    ++calls;
    cpu().column_sums_accumulate(host_alias(d_y), host_alias(d_bias));
  }
  void axpby(float alpha, const Tensor& a, float beta, const Tensor& b, const Tensor& y) override {
    ++calls;
    cpu().axpby(alpha, host_alias(a), beta, host_alias(b), host_alias(y));
  }
  void axpy(float alpha, const Tensor& x, const Tensor& y) override {
    ++calls;
    cpu().axpy(alpha, host_alias(x), host_alias(y));
  }
  void mul(const Tensor& a, const Tensor& b, const Tensor& y) override {
    ++calls;
    cpu().mul(host_alias(a), host_alias(b), host_alias(y));
  }
  void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a) override {
    ++calls;
    cpu().mul_accumulate(host_alias(b), host_alias(d_y), host_alias(d_a));
  }
  void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope) override {
    ++calls;
    cpu().activation_forward(f, host_alias(x), host_alias(y), slope);
  }
  void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y, const Tensor& d_x, float slope, bool accumulate) override {
    ++calls;
    cpu().activation_backward(f, host_alias(x), host_alias(y), host_alias(d_y), host_alias(d_x), slope, accumulate);
  }
  void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y) override {
    ++calls;
    cpu().row_softmax_forward(host_alias(x), host_alias(mask), host_alias(y));
  }
  void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x) override {
    ++calls;
    cpu().row_softmax_backward(host_alias(y), host_alias(d_y), host_alias(d_x));
  }
  void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum, const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd, const Tensor& running_mean, const Tensor& running_var) override {
    ++calls;
    cpu().batchnorm_train_forward(host_alias(x), host_alias(gamma), host_alias(beta), eps, momentum, host_alias(y), host_alias(save_mean), host_alias(save_invstd), host_alias(running_mean), host_alias(running_var));
  }
  void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& running_mean, const Tensor& running_var, float eps, const Tensor& y) override {
    ++calls;
    cpu().batchnorm_eval_forward(host_alias(x), host_alias(gamma), host_alias(beta), host_alias(running_mean), host_alias(running_var), eps, host_alias(y));
  }
  void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean, const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta, bool accumulate_dx) override {
    ++calls;
    cpu().batchnorm_train_backward(host_alias(x), host_alias(gamma), host_alias(save_mean), host_alias(save_invstd), host_alias(d_y), host_alias(d_x), host_alias(d_gamma), host_alias(d_beta), accumulate_dx);
  }
  void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean, const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta) override {
    ++calls;
    cpu().batchnorm_eval_backward(host_alias(x), host_alias(gamma), host_alias(running_mean), host_alias(running_var), eps, host_alias(d_y), host_alias(d_x), host_alias(d_gamma), host_alias(d_beta));
  }
  void sum_all(const Tensor& x, const Tensor& out) override {
    ++calls;
    cpu().sum_all(host_alias(x), host_alias(out));
  }
  void add_scalar_accumulate(const Tensor& s, float scale, const Tensor& d_x) override {
    ++calls;
    cpu().add_scalar_accumulate(host_alias(s), scale, host_alias(d_x));
  }
  void mse_forward(const Tensor& pred, const Tensor& target, const Tensor& out) override {
    ++calls;
    cpu().mse_forward(host_alias(pred), host_alias(target), host_alias(out));
  }
  void mse_backward(const Tensor& pred, const Tensor& target, const Tensor& d_out, const Tensor& d_pred) override {
    ++calls;
    cpu().mse_backward(host_alias(pred), host_alias(target), host_alias(d_out), host_alias(d_pred));
  }
  void kl_div_forward(const Tensor& pred, const Tensor& target, float eps, const Tensor& out) override {
    ++calls;
    cpu().kl_div_forward(host_alias(pred), host_alias(target), eps, host_alias(out));
  }
  void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, const Tensor& d_out, const Tensor& d_pred) override {
    ++calls;
    cpu().kl_div_backward(host_alias(pred), host_alias(target), eps, host_alias(d_out), host_alias(d_pred));
  }
  void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr, float beta1, float beta2, float eps, float weight_decay, long step) override {
    ++calls;
    cpu().adam_update(host_alias(param), host_alias(grad), host_alias(m), host_alias(v), lr, beta1, beta2, eps, weight_decay, step);
  }
  void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el, const Tensor& er) override {
    ++calls;
    cpu().attention_projection_forward(host_alias(z), host_alias(a_l), host_alias(a_r), host_alias(el), host_alias(er));
  }
  void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& d_el, const Tensor& d_er, const Tensor& d_z, const Tensor& d_al, const Tensor& d_ar) override {
    ++calls;
    cpu().attention_projection_backward(host_alias(z), host_alias(a_l), host_alias(a_r), host_alias(d_el), host_alias(d_er), host_alias(d_z), host_alias(d_al), host_alias(d_ar));
  }
  void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope, const Tensor& alpha) override {
    ++calls;
    cpu().edge_softmax_additive_forward(g, host_alias(el), host_alias(er), slope, host_alias(alpha));
  }
  void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha) override {
    ++calls;
    cpu().edge_softmax_dot_forward(g, host_alias(h), heads, scale, host_alias(alpha));
  }
  void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope, const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el, const Tensor& d_er) override {
    ++calls;
    cpu().edge_softmax_additive_backward(g, host_alias(el), host_alias(er), slope, host_alias(alpha), host_alias(d_alpha), host_alias(d_el), host_alias(d_er));
  }
  void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_h) override {
    ++calls;
    cpu().edge_softmax_dot_backward(g, host_alias(h), heads, scale, host_alias(alpha), host_alias(d_alpha), host_alias(d_h));
  }
  void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out) override {
    ++calls;
    cpu().aggregate_forward(g, host_alias(alpha), host_alias(z), host_alias(out));
  }
  void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out, const Tensor& d_alpha, const Tensor& d_z) override {
    ++calls;
    cpu().aggregate_backward(g, host_alias(alpha), host_alias(z), host_alias(d_out), host_alias(d_alpha), host_alias(d_z));
  }
  void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope, const Tensor& out, const Tensor& alpha) override {
    ++calls;
    cpu().gat_fused_additive_forward(g, host_alias(z), host_alias(el), host_alias(er), slope, host_alias(out), host_alias(alpha));
  }
  void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& out, const Tensor& alpha) override {
    ++calls;
    cpu().gat_fused_dot_forward(g, host_alias(z), heads, scale, host_alias(out), host_alias(alpha));
  }
  void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z, const Tensor& d_el, const Tensor& d_er) override {
    ++calls;
    cpu().gat_fused_additive_backward(g, host_alias(z), host_alias(el), host_alias(er), slope, host_alias(alpha), host_alias(d_out), host_alias(d_z), host_alias(d_el), host_alias(d_er));
  }
  void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z) override {
    ++calls;
    cpu().gat_fused_dot_backward(g, host_alias(z), heads, scale, host_alias(alpha), host_alias(d_out), host_alias(d_z));
  }
  void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out, const Tensor& argmax) override {
    ++calls;
    cpu().segment_max_forward(host_alias(x), seg_ptr, host_alias(out), host_alias(argmax));
  }
  void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x) override {
    ++calls;
    cpu().segment_max_backward(host_alias(d_out), host_alias(argmax), host_alias(d_x));
  }
  void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out) override {
    ++calls;
    cpu().broadcast_segments_forward(host_alias(x), seg_ptr, host_alias(out));
  }
  void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg_ptr, const Tensor& d_x) override {
    ++calls;
    cpu().broadcast_segments_backward(host_alias(d_out), seg_ptr, host_alias(d_x));
  }
  void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out) override {
    ++calls;
    cpu().neighbour_mean_forward(nbr, host_alias(x), host_alias(out));
  }
  void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x) override {
    ++calls;
    cpu().neighbour_mean_backward(nbr, host_alias(d_out), host_alias(d_x));
  }
};

}  // namespace

TEST_CASE("ops run on the backend of their tensors' device", "[backend]") {
  REQUIRE_THROWS_WITH(backend(Device::vulkan), Catch::Contains("no backend for device 'vulkan'"));
  FakeDeviceBackend fake;
  register_backend(&fake);
  std::mt19937 rng(11);
  GraphPtr g = share(fixtures::grid_graph(5, 4, 1));
  const std::int64_t n = g->num_nodes;
  Tensor x = gradcheck::random_tensor(n, 6, rng), W = gradcheck::random_tensor(6, 8, rng);
  Tensor al = gradcheck::random_tensor(2, 4, rng), ar = gradcheck::random_tensor(2, 4, rng);
  Tensor target = gradcheck::random_tensor(n, 8, rng);

  auto run = [&](Device d, Tensor& loss, Tensor& gW, Tensor& gal) {
    Var xv(to(x, d)), Wv(to(W, d), true), lv(to(al, d), true), rv(to(ar, d), true);
    Var y = tanh(gat_additive(g, linear(xv, Wv, Var{}), lv, rv));
    Var l = mse_loss(y, to(target, d));
    backward(l);
    REQUIRE(y.device() == d);
    REQUIRE(Wv.grad().device() == d);
    loss = to(l.value(), Device::cpu);
    gW = to(Wv.grad(), Device::cpu);
    gal = to(lv.grad(), Device::cpu);
  };
  Tensor l_cpu, gW_cpu, gal_cpu, l_dev, gW_dev, gal_dev;
  run(Device::cpu, l_cpu, gW_cpu, gal_cpu);
  REQUIRE(fake.calls == 0);
  run(Device::vulkan, l_dev, gW_dev, gal_dev);
  REQUIRE(fake.calls > 10);
  REQUIRE(l_dev.at(0, 0) == l_cpu.at(0, 0));
  for (std::int64_t i = 0; i < gW_cpu.numel(); ++i)
    REQUIRE(gW_dev.at(i / gW_cpu.cols(), i % gW_cpu.cols()) == gW_cpu.at(i / gW_cpu.cols(), i % gW_cpu.cols()));
  for (std::int64_t i = 0; i < gal_cpu.numel(); ++i)
    REQUIRE(gal_dev.at(i / gal_cpu.cols(), i % gal_cpu.cols()) == gal_cpu.at(i / gal_cpu.cols(), i % gal_cpu.cols()));

  // Mixing devices in one op is an error that names both.
  REQUIRE_THROWS_WITH(linear(Var(x), Var(to(W, Device::vulkan)), Var{}),
                      Catch::Contains("different devices (cpu and vulkan)"));
  unregister_backend(Device::vulkan);
  REQUIRE_FALSE(has_backend(Device::vulkan));
}
