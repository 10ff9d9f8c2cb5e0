#pragma once
// Every differentiable op calls its kernels through the Backend of the device
// its tensors live on, never the CPU kernels directly, so the same model code
// runs wherever its tensors are. The CPU backend is always registered; a
// Vulkan backend registers itself when built.
//
// Conventions (the same as src/backends/cpu/*.hpp): gradient outputs are accumulated
// (+=) and may be undefined tensors meaning "not wanted"; forward outputs are
// overwritten. Scalars (losses, sums) stay on the device as [1, 1] tensors.
#include <cstdint>
#include <span>

#include "gatcore/activation.hpp"
#include "gatcore/batch_split.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore {

class Backend {
 public:
  virtual ~Backend() = default;
  virtual Device device() const = 0;

  // Memory.
  virtual Tensor empty(std::int64_t rows, std::int64_t cols, DType dt = DType::f32) = 0;
  virtual Tensor zeros(std::int64_t rows, std::int64_t cols, DType dt = DType::f32) = 0;
  virtual void fill(const Tensor& y, float value) = 0;
  virtual void copy(const Tensor& src, const Tensor& dst) = 0;  // same shape, strided
  // Transfers: a device copy of a CPU tensor, and a CPU copy of a device one.
  virtual Tensor from_host(const Tensor& host) = 0;
  virtual Tensor to_host(const Tensor& t) = 0;

  // Dense algebra.
  virtual void gemm(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha,
                    float beta) = 0;
  // The same product with both operands rounded to bf16 and fp32 sums
  // (Precision::bf16, precision.hpp), where bf16_products() says the backend
  // has it; the default runs gemm (fp32).
  virtual bool bf16_products() const { return false; }
  virtual void gemm_bf16(const Tensor& A, bool trans_a, const Tensor& B, bool trans_b, const Tensor& C, float alpha,
                         float beta) {
    gemm(A, trans_a, B, trans_b, C, alpha, beta);
  }
  virtual void add_row_bias(const Tensor& bias, const Tensor& y) = 0;
  virtual void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias) = 0;
  virtual void axpby(float alpha, const Tensor& a, float beta, const Tensor& b, const Tensor& y) = 0;
  virtual void axpy(float alpha, const Tensor& x, const Tensor& y) = 0;
  virtual void mul(const Tensor& a, const Tensor& b, const Tensor& y) = 0;
  virtual void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a) = 0;
  virtual void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope) = 0;
  // accumulate: d_x += the gradient; false: d_x = the gradient, d_x's
  // contents ignored (a fresh buffer needs no zero fill; the same values as
  // accumulating onto zeros). The BatchNorm backwards' accumulate_dx alike.
  virtual void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y,
                                   const Tensor& d_x, float slope, bool accumulate) = 0;
  virtual void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y) = 0;
  virtual void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x) = 0;
  virtual void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                       float momentum, const Tensor& y, const Tensor& save_mean,
                                       const Tensor& save_invstd, const Tensor& running_mean,
                                       const Tensor& running_var) = 0;
  virtual void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta,
                                      const Tensor& running_mean, const Tensor& running_var, float eps,
                                      const Tensor& y) = 0;
  virtual void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                                        const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                                        const Tensor& d_gamma, const Tensor& d_beta, bool accumulate_dx) = 0;
  virtual void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                                       const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                                       const Tensor& d_gamma, const Tensor& d_beta) = 0;
  // SyncBatchNorm (a batch split over processes, batch_split.hpp): the
  // training forward / backward with their statistics summed through
  // `across`. Only the CPU backend has them; the default says so.
  virtual void batchnorm_train_forward_across(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                              float momentum, const Tensor& y, const Tensor& save_mean,
                                              const Tensor& save_invstd, const Tensor& running_mean,
                                              const Tensor& running_var, const SumAcross& across);
  virtual void batchnorm_train_backward_across(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                                               const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                                               const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across);

  // BatchNorm (training) fused with the activation after it (identity, relu,
  // leaky_relu; src/backends/cpu/batchnorm.hpp batchnorm_act_*): backward recomputes
  // the normalised value and the activation's sign from x and the saved
  // statistics instead of keeping them. save_mean / save_invstd [1, C] are
  // batchnorm_train_forward's; save_affine [2, C] is the backend's own. apply
  // recomputes y (the forward's values). The defaults compose the unfused
  // kernels (the same values, more passes and temporaries) for backends
  // without fused kernels.
  virtual void batchnorm_act_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                           float momentum, Activation f, float slope, const Tensor& y,
                                           const Tensor& save_mean, const Tensor& save_invstd,
                                           const Tensor& save_affine, const Tensor& running_mean,
                                           const Tensor& running_var, const SumAcross& across);
  virtual void batchnorm_act_apply(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, Activation f,
                                   float slope, const Tensor& save_mean, const Tensor& save_affine, const Tensor& y);
  virtual void batchnorm_act_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                            Activation f, float slope, const Tensor& save_mean,
                                            const Tensor& save_invstd, const Tensor& save_affine, const Tensor& d_y,
                                            const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta,
                                            const SumAcross& across, bool accumulate_dx);

  // Reductions and losses into [1, 1] tensors; backward takes d_out as [1, 1].
  virtual void sum_all(const Tensor& x, const Tensor& out) = 0;
  virtual void add_scalar_accumulate(const Tensor& s, float scale, const Tensor& d_x) = 0;  // d_x += scale*s[0,0]
  virtual void mse_forward(const Tensor& pred, const Tensor& target, const Tensor& out) = 0;
  virtual void mse_backward(const Tensor& pred, const Tensor& target, const Tensor& d_out,
                            const Tensor& d_pred) = 0;
  virtual void kl_div_forward(const Tensor& pred, const Tensor& target, float eps, const Tensor& out) = 0;
  virtual void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, const Tensor& d_out,
                               const Tensor& d_pred) = 0;

  // Optimiser (src/backends/cpu/optimizer.hpp).
  virtual void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr,
                           float beta1, float beta2, float eps, float weight_decay, long step) = 0;

  // Graph attention (see src/backends/cpu/attention_projection.hpp, edge_softmax.hpp,
  // aggregation.hpp, gat_fused.hpp).
  virtual void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r,
                                            const Tensor& el, const Tensor& er) = 0;
  virtual void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r,
                                             const Tensor& d_el, const Tensor& d_er, const Tensor& d_z,
                                             const Tensor& d_al, const Tensor& d_ar) = 0;
  virtual void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                             const Tensor& alpha) = 0;
  virtual void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale,
                                        const Tensor& alpha) = 0;
  virtual void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                              const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el,
                                              const Tensor& d_er) = 0;
  virtual void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale,
                                         const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_h) = 0;
  virtual void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out) = 0;
  virtual void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out,
                                  const Tensor& d_alpha, const Tensor& d_z) = 0;
  virtual void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                          float slope, const Tensor& out, const Tensor& alpha) = 0;
  virtual void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale,
                                     const Tensor& out, const Tensor& alpha) = 0;
  virtual void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el,
                                           const Tensor& er, float slope, const Tensor& alpha,
                                           const Tensor& d_out, const Tensor& d_z, const Tensor& d_el,
                                           const Tensor& d_er) = 0;
  virtual void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale,
                                      const Tensor& alpha, const Tensor& d_out, const Tensor& d_z) = 0;

  // Pooling (src/backends/cpu/pooling.hpp).
  virtual void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr, const Tensor& out,
                                   const Tensor& argmax) = 0;
  virtual void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x) = 0;
  virtual void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg_ptr,
                                          const Tensor& out) = 0;
  virtual void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg_ptr,
                                           const Tensor& d_x) = 0;
  virtual void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out) = 0;
  virtual void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x) = 0;
};

// The backend for a device; throws Error naming the device if none is available.
Backend& backend(Device d);
// Registers (or replaces) the backend of its device; the pointer must outlive its use.
void register_backend(Backend* b);
bool has_backend(Device d);
// Removes the backend of a device (not the CPU one); tests use it.
void unregister_backend(Device d);

// Moves / copies a tensor to another device (a no-op view when already there).
Tensor to(const Tensor& t, Device d);

// The SIMD path the CPU kernels take now ("scalar", "avx2", "avx512";
// GATCORE_SIMD may force a lower one) and the best this CPU supports.
const char* cpu_simd_level_name();
const char* cpu_detected_simd_level_name();

}  // namespace gatcore
