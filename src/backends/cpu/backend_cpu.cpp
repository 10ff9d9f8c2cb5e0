// The CPU backend: forwards every Backend entry to the kernels in this folder.
#include "src/backends/cpu/backend_cpu.hpp"
#include "src/backends/cpu/aggregation.hpp"
#include "src/backends/cpu/attention_projection.hpp"
#include "src/backends/cpu/batchnorm.hpp"
#include "src/backends/cpu/dense_concat.hpp"
#include "src/backends/cpu/edge_softmax.hpp"
#include "src/backends/cpu/elementwise.hpp"
#include "src/backends/cpu/gat_fused.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/loss.hpp"
#include "src/backends/cpu/optimizer.hpp"
#include "src/backends/cpu/pooling.hpp"
#include "src/backends/cpu/row_softmax.hpp"

namespace gatcore {


namespace {

class CpuBackend final : public Backend {
 public:
  Device device() const override { return Device::cpu; }

  Tensor empty(std::int64_t r, std::int64_t c, DType dt) override { return Tensor::empty(r, c, dt); }
  Tensor zeros(std::int64_t r, std::int64_t c, DType dt) override { return Tensor::zeros(r, c, dt); }
  void fill(const Tensor& y, float v) override { cpu::fill(y, v); }
  void copy(const Tensor& src, const Tensor& dst) override { cpu::concat_copy_forward(src, dst, 0); }
  Tensor from_host(const Tensor& host) override { return host.clone(); }
  Tensor to_host(const Tensor& t) override { return t.clone(); }

  void gemm(const Tensor& A, bool ta, const Tensor& B, bool tb, const Tensor& C, float alpha,
            float beta) override {
    cpu::gemm(A, ta, B, tb, C, alpha, beta);
  }
  bool bf16_products() const override { return bf16_supported(); }
  void gemm_bf16(const Tensor& A, bool ta, const Tensor& B, bool tb, const Tensor& C, float alpha,
                 float beta) override {
    cpu::gemm(A, ta, B, tb, C, alpha, beta, Precision::bf16);
  }
  void add_row_bias(const Tensor& bias, const Tensor& y) override { cpu::add_row_bias(bias, y); }
  void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias) override {
    cpu::column_sums_accumulate(d_y, d_bias);
  }
  void axpby(float a, const Tensor& x, float b, const Tensor& y, const Tensor& out) override {
    cpu::axpby(a, x, b, y, out);
  }
  void axpy(float a, const Tensor& x, const Tensor& y) override { cpu::axpy(a, x, y); }
  void mul(const Tensor& a, const Tensor& b, const Tensor& y) override { cpu::mul(a, b, y); }
  void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a) override {
    cpu::mul_accumulate(b, d_y, d_a);
  }
  void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope) override {
    cpu::activation_forward(f, x, y, slope);
  }
  void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y, const Tensor& d_x,
                           float slope, bool accumulate) override {
    cpu::activation_backward(f, x, y, d_y, d_x, slope, accumulate);
  }
  void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y) override {
    cpu::row_softmax_forward(x, mask, y);
  }
  void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x) override {
    cpu::row_softmax_backward(y, d_y, d_x);
  }
  void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                               const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd,
                               const Tensor& running_mean, const Tensor& running_var) override {
    cpu::batchnorm_train_forward(x, gamma, beta, eps, momentum, y, save_mean, save_invstd, running_mean,
                                 running_var);
  }
  void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& rm,
                              const Tensor& rv, float eps, const Tensor& y) override {
    cpu::batchnorm_eval_forward(x, gamma, beta, rm, rv, eps, y);
  }
  void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                                const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                                const Tensor& d_gamma, const Tensor& d_beta, bool accumulate_dx) override {
    cpu::batchnorm_train_backward(x, gamma, save_mean, save_invstd, d_y, d_x, d_gamma, d_beta, {}, accumulate_dx);
  }
  void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& rm, const Tensor& rv, float eps,
                               const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma,
                               const Tensor& d_beta) override {
    cpu::batchnorm_eval_backward(x, gamma, rm, rv, eps, d_y, d_x, d_gamma, d_beta);
  }
  void batchnorm_train_forward_across(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                      float momentum, const Tensor& y, const Tensor& save_mean,
                                      const Tensor& save_invstd, const Tensor& running_mean,
                                      const Tensor& running_var, const SumAcross& across) override {
    cpu::batchnorm_train_forward(x, gamma, beta, eps, momentum, y, save_mean, save_invstd, running_mean, running_var,
                                 across);
  }
  void batchnorm_train_backward_across(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                                       const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                                       const Tensor& d_gamma, const Tensor& d_beta,
                                       const SumAcross& across) override {
    cpu::batchnorm_train_backward(x, gamma, save_mean, save_invstd, d_y, d_x, d_gamma, d_beta, across);
  }
  void batchnorm_act_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                   float momentum, Activation f, float slope, const Tensor& y,
                                   const Tensor& save_mean, const Tensor& save_invstd, const Tensor& save_affine,
                                   const Tensor& running_mean, const Tensor& running_var,
                                   const SumAcross& across) override {
    cpu::batchnorm_act_train_forward(x, gamma, beta, eps, momentum, f, slope, y, save_mean, save_invstd, save_affine,
                                     running_mean, running_var, across);
  }
  void batchnorm_act_apply(const Tensor& x, const Tensor&, const Tensor& beta, float, Activation f, float slope,
                           const Tensor& save_mean, const Tensor& save_affine, const Tensor& y) override {
    cpu::batchnorm_act_apply(x, beta, f, slope, save_mean, save_affine, y);
  }
  void batchnorm_act_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float, Activation f,
                                    float slope, const Tensor& save_mean, const Tensor& save_invstd,
                                    const Tensor& save_affine, const Tensor& d_y, const Tensor& d_x,
                                    const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across,
                                    bool accumulate_dx) override {
    cpu::batchnorm_act_train_backward(x, gamma, beta, f, slope, save_mean, save_invstd, save_affine, d_y, d_x,
                                      d_gamma, d_beta, across, accumulate_dx);
  }

  void sum_all(const Tensor& x, const Tensor& out) override {
    out.at(0, 0) = static_cast<float>(cpu::sum_all(x));
  }
  void add_scalar_accumulate(const Tensor& s, float scale, const Tensor& d_x) override {
    const float v = scale * s.at(0, 0);
    for (std::int64_t r = 0; r < d_x.rows(); ++r) {
      float* p = d_x.row(r);
      for (std::int64_t c = 0; c < d_x.cols(); ++c) p[c] += v;
    }
  }
  void mse_forward(const Tensor& pred, const Tensor& target, const Tensor& out) override {
    out.at(0, 0) = static_cast<float>(cpu::mse_forward(pred, target));
  }
  void mse_backward(const Tensor& pred, const Tensor& target, const Tensor& d_out, const Tensor& d_pred) override {
    cpu::mse_backward(pred, target, d_out.at(0, 0), d_pred);
  }
  void kl_div_forward(const Tensor& pred, const Tensor& target, float eps, const Tensor& out) override {
    out.at(0, 0) = static_cast<float>(cpu::kl_div_forward(pred, target, eps));
  }
  void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, const Tensor& d_out,
                       const Tensor& d_pred) override {
    cpu::kl_div_backward(pred, target, eps, d_out.at(0, 0), d_pred);
  }

  void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr, float beta1,
                   float beta2, float eps, float weight_decay, long step) override {
    cpu::adam_update(param, grad, m, v, lr, beta1, beta2, eps, weight_decay, step);
  }

  void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                    const Tensor& er) override {
    cpu::attention_projection_forward(z, a_l, a_r, el, er);
  }
  void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& d_el,
                                     const Tensor& d_er, const Tensor& d_z, const Tensor& d_al,
                                     const Tensor& d_ar) override {
    cpu::attention_projection_backward(z, a_l, a_r, d_el, d_er, d_z, d_al, d_ar);
  }
  void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                     const Tensor& alpha) override {
    cpu::edge_softmax_additive_forward(g, el, er, slope, alpha);
  }
  void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale,
                                const Tensor& alpha) override {
    cpu::edge_softmax_dot_forward(g, h, heads, scale, alpha);
  }
  void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                      const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el,
                                      const Tensor& d_er) override {
    cpu::edge_softmax_additive_backward(g, el, er, slope, alpha, d_alpha, d_el, d_er);
  }
  void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha,
                                 const Tensor& d_alpha, const Tensor& d_h) override {
    cpu::edge_softmax_dot_backward(g, h, heads, scale, alpha, d_alpha, d_h);
  }
  void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out) override {
    cpu::aggregate_forward(g, alpha, z, out);
  }
  void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out,
                          const Tensor& d_alpha, const Tensor& d_z) override {
    cpu::aggregate_backward(g, alpha, z, d_out, d_alpha, d_z);
  }
  void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                  float slope, const Tensor& out, const Tensor& alpha) override {
    cpu::gat_fused_additive_forward(g, z, el, er, slope, out, alpha);
  }
  void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& out,
                             const Tensor& alpha) override {
    cpu::gat_fused_dot_forward(g, z, heads, scale, out, alpha);
  }
  void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                   float slope, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z,
                                   const Tensor& d_el, const Tensor& d_er) override {
    cpu::gat_fused_additive_backward(g, z, el, er, slope, alpha, d_out, d_z, d_el, d_er);
  }
  void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& alpha,
                              const Tensor& d_out, const Tensor& d_z) override {
    cpu::gat_fused_dot_backward(g, z, heads, scale, alpha, d_out, d_z);
  }

  void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg, const Tensor& out,
                           const Tensor& argmax) override {
    cpu::segment_max_forward(x, seg, out, argmax);
  }
  void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x) override {
    cpu::segment_max_backward(d_out, argmax, d_x);
  }
  void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg, const Tensor& out) override {
    cpu::broadcast_segments_forward(x, seg, out);
  }
  void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg,
                                   const Tensor& d_x) override {
    cpu::broadcast_segments_backward(d_out, seg, d_x);
  }
  void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out) override {
    cpu::neighbour_mean_forward(nbr, x, out);
  }
  void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x) override {
    cpu::neighbour_mean_backward(nbr, d_out, d_x);
  }
};

CpuBackend g_cpu;

}  // namespace

Backend& cpu_backend() { return g_cpu; }

}  // namespace gatcore
