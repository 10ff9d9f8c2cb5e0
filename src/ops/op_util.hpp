#pragma once
// Shared plumbing of the differentiable ops (not installed).
#include <initializer_list>

#include "gatcore/autograd.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/ops.hpp"
#include "gatcore/precision.hpp"

namespace gatcore::ops_detail {

using ImplPtr = std::shared_ptr<VarImpl>;

// The backend all (defined) inputs live on; throws naming the op if they differ.
Backend& backend_of(const char* op, std::initializer_list<const Var*> inputs);

// The output Var: `into` (shape-checked, marked requires_grad as needed) or a
// fresh [rows, cols] tensor on the backend.
Var make_output(const char* op, Backend& be, std::int64_t rows, std::int64_t cols, const Var& into, bool grad);

void check_var(const char* op, const char* arg, const Var& v);
void check_same_shape(const char* op, const char* a_name, const Tensor& a, const char* b_name, const Tensor& b);

// The precision of an op's products (precision.hpp): the scope's when the op
// runs forward, fp32 on a backend without bf16 products. Ops capture it in
// their tape record so backward multiplies as forward did.
// Products over fewer than kBf16MinK terms (k = the input width) stay fp32:
// too small to gain, and a broadcast through a ones column (Ori.GAT's bias,
// matmul(ones, b)) would round the broadcast operand itself.
constexpr std::int64_t kBf16MinK = 16;
inline Precision product_precision(const Backend& be, std::int64_t k) {
  return be.bf16_products() && k >= kBf16MinK ? current_product_precision() : Precision::fp32;
}
inline void product(Backend& be, Precision p, const Tensor& A, bool trans_a, const Tensor& B, bool trans_b,
                    const Tensor& C, float alpha, float beta) {
  if (p == Precision::bf16)
    be.gemm_bf16(A, trans_a, B, trans_b, C, alpha, beta);
  else
    be.gemm(A, trans_a, B, trans_b, C, alpha, beta);
}

// Gradient buffer of an input if it wants one, else undefined (kernels skip it).
inline Tensor grad_for(const ImplPtr& p) { return p && p->requires_grad ? p->grad_or_zeros() : Tensor{}; }
inline ImplPtr impl_if(const Var& v) { return v.defined() ? v.impl() : nullptr; }

// Where an input's gradient goes, and whether a kernel adds to it: a
// parameter or tensor whose gradient has not arrived yet gets an
// uninitialised buffer to write (accumulate = false: no zero fill, no extra
// pass); otherwise (also for every view, whose base may hold other
// gradients) the kernel accumulates. An input without a gradient: undefined.
struct GradTarget {
  Tensor grad;
  bool accumulate = true;
};
inline GradTarget grad_target(Backend& be, const ImplPtr& p) {
  if (!p || !p->requires_grad) return {};
  if (!p->base && !p->grad.defined()) {
    p->grad = be.empty(p->value.rows(), p->value.cols());
    return {p->grad, false};
  }
  return {p->grad_or_zeros(), true};
}

// Runs kernel(grad, beta) for a kernel that computes grad = beta grad + term
// (grad_target: beta = 0 for a fresh buffer, else 1). Either way the term is
// computed the same way, so the result is bitwise the same as accumulating
// onto zeros.
template <class F>
void accumulate_grad(Backend& be, const ImplPtr& p, F&& kernel) {
  if (!p || !p->requires_grad) return;
  const GradTarget t = grad_target(be, p);
  kernel(t.grad, t.accumulate ? 1.0f : 0.0f);
}

// Adds the result of a kernel that *overwrites* its gradient output: straight
// into a fresh gradient, or through a temporary when one already exists.
template <class F>
void overwrite_grad_into(Backend& be, const ImplPtr& p, F&& kernel) {
  if (!p || !p->requires_grad) return;
  Tensor g = p->grad_if_any();
  if (!g.defined()) {
    kernel(p->grad_or_zeros());
  } else {
    Tensor tmp = be.empty(g.rows(), g.cols());
    kernel(tmp);
    be.axpy(1.0f, tmp, g);
  }
}

// linear's products (ops/dense_ops.cpp), shared by every op that applies a
// Linear layer's weight, so that how a layer's product is computed is decided
// in one place: y = x·W, dx = dy·Wᵀ + beta·dx, dW = xᵀ·dy + beta·dW.
// `p`: the precision the op took at forward time (product_precision).
void linear_product(Backend& be, Precision p, const Tensor& x, const Tensor& W, const Tensor& y);
void linear_input_grad(Backend& be, Precision p, const Tensor& dy, const Tensor& W, const Tensor& dx, float beta);
void linear_weight_grad(Backend& be, Precision p, const Tensor& x, const Tensor& dy, const Tensor& dW, float beta);

// batch_norm's argument checks and running statistics (created on first
// use), shared with the fused BatchNorm ops; when training under a batch
// split over processes (batch_split.hpp), the sum of its statistics
// (SyncBatchNorm; a placeholder share adds zeros).
struct BatchNormSetup {
  Backend* be = nullptr;
  SumAcross across;          // set under a batch split
  bool placeholder = false;  // this process's rows are not in the batch
};
BatchNormSetup batch_norm_setup(const char* op, const Var& x, const Var& gamma, const Var& beta, BatchNormState& st,
                                bool training);

}  // namespace gatcore::ops_detail
