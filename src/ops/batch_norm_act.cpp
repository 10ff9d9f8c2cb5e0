// The fused BatchNorm (training) → activation ops. Why: in a dense layer
// Linear → BatchNorm → activation the unfused ops keep three [n, width]
// tensors for backward (the Linear's output, the normalised value, the
// activation output) and make two extra passes over them; these keep the
// Linear's output only and recompute the rest, the cheap pointwise part, in
// backward (what torch.compile's min-cut partitioner does).
#include "src/ops/op_util.hpp"

namespace gatcore {
using namespace ops_detail;

namespace {

// What the fused forward saves, and its backward from d_y (the gradient of
// the activation output).
struct FusedBatchNorm {
  Backend* be;
  Activation f;
  float slope, eps;
  SumAcross across;
  bool placeholder;
  SavedTensor x, gamma, beta;
  Tensor mean, invstd, affine;  // the batch statistics (the op's own, never modified)

  void backward(const char* op, Tensor d_y, const ImplPtr& xi, const ImplPtr& gi, const ImplPtr& bi) const {
    const Tensor& xv = x.get(op);
    if (!d_y.defined()) {
      // Across processes every process takes part in the sums, gradient or not.
      if (!across) return;
      d_y = be->zeros(xv.rows(), xv.cols());
    }
    // A placeholder's rows are not in the batch: no gradient flows from them.
    const GradTarget dx = placeholder ? GradTarget{} : grad_target(*be, xi);
    be->batchnorm_act_train_backward(xv, gamma.get(op), beta.get(op), eps, f, slope, mean, invstd, affine, d_y,
                                     dx.grad, grad_for(gi), grad_for(bi), across, dx.accumulate);
  }
};

FusedBatchNorm fused_forward(const char* op, const Var& x, const Var& gamma, const Var& beta, BatchNormState& st,
                             Activation f, float slope, const Tensor& y) {
  const BatchNormSetup setup = batch_norm_setup(op, x, gamma, beta, st, true);
  Backend& be = *setup.be;
  const std::int64_t C = x.cols();
  FusedBatchNorm s{&be,
                   f,
                   slope,
                   st.eps,
                   setup.across,
                   setup.placeholder,
                   SavedTensor(x.value(), "x"),
                   SavedTensor(gamma.value(), "gamma"),
                   SavedTensor(beta.value(), "beta"),
                   be.empty(1, C),
                   be.empty(1, C),
                   be.empty(2, C)};
  be.batchnorm_act_train_forward(x.value(), gamma.value(), beta.value(), st.eps, st.momentum, f, slope, y, s.mean,
                                 s.invstd, s.affine, st.running_mean, st.running_var, s.across);
  return s;
}

}  // namespace

Var batch_norm_act(const Var& x, const Var& gamma, const Var& beta, BatchNormState& st, Activation f, float slope,
                   const Var& into) {
  static const char* op = "batch_norm_act";
  check_var(op, "x", x);
  Backend& be = backend_of(op, {&x, &gamma, &beta});
  const bool grad = needs_grad({&x, &gamma, &beta});
  Var y = make_output(op, be, x.rows(), x.cols(), into, grad);
  FusedBatchNorm s = fused_forward(op, x, gamma, beta, st, f, slope, y.value());
  if (grad)
    current_tape().record(op, [s = std::move(s), xi = x.impl(), gi = gamma.impl(), bi = beta.impl(), yi = y.impl()] {
      s.backward(op, yi->grad_if_any(), xi, gi, bi);
    });
  return y;
}

Var batch_norm_act_linear(const Var& x, const Var& gamma, const Var& beta, BatchNormState& st, Activation f,
                          float slope, const Var& W, const Var& b) {
  static const char* op = "batch_norm_act_linear";
  check_var(op, "x", x);
  check_var(op, "W", W);
  GATCORE_CHECK(x.cols() == W.rows(), op, ": x ", x.value().shape_str(), " does not match W ", W.value().shape_str(),
                " (x.cols must equal W.rows)");
  if (b.defined())
    GATCORE_CHECK(b.rows() == 1 && b.cols() == W.cols(), op, ": bias ", b.value().shape_str(), " must be [1, ",
                  W.cols(), "]");
  Backend& be = backend_of(op, {&x, &gamma, &beta, &W, &b});
  const bool grad = needs_grad({&x, &gamma, &beta, &W, &b});
  Var out = make_output(op, be, x.rows(), W.cols(), Var{}, grad);
  FusedBatchNorm s;
  const Precision prec = product_precision(be, x.cols());  // linear's rule; backward uses the same
  {
    // The activation: the product's input, dropped as soon as it is used.
    Tensor a = be.empty(x.rows(), x.cols());
    s = fused_forward(op, x, gamma, beta, st, f, slope, a);
    linear_product(be, prec, a, W.value(), out.value());
  }
  if (b.defined()) be.add_row_bias(b.value(), out.value());
  if (grad)
    current_tape().record(op, [s = std::move(s), prec, xi = x.impl(), gi = gamma.impl(), bi = beta.impl(),
                               Wi = W.impl(), lbi = impl_if(b), oi = out.impl(), Ws = SavedTensor(W.value(), "W")] {
      const Tensor d_out = oi->grad_if_any();
      if (!d_out.defined()) {
        s.backward(op, Tensor{}, xi, gi, bi);  // the sums across processes, if any
        return;
      }
      const Tensor& xv = s.x.get(op);
      const bool want_input = (xi->requires_grad && !s.placeholder) || gi->requires_grad || bi->requires_grad;
      // One [n, width] temporary: the activation again (W's gradient), then
      // its gradient d_out·Wᵀ written over it.
      Tensor a = s.be->empty(xv.rows(), xv.cols());
      if (Wi->requires_grad) {
        s.be->batchnorm_act_apply(xv, s.gamma.get(op), s.beta.get(op), s.eps, s.f, s.slope, s.mean, s.affine, a);
        accumulate_grad(*s.be, Wi,
                        [&](const Tensor& dW, float beta) { linear_weight_grad(*s.be, prec, a, d_out, dW, beta); });
      }
      if (lbi && lbi->requires_grad) s.be->column_sums_accumulate(d_out, lbi->grad_or_zeros());
      if (!want_input && !s.across) return;
      linear_input_grad(*s.be, prec, d_out, Ws.get(op), a, 0.0f);
      s.backward(op, a, xi, gi, bi);
    });
  return out;
}

}  // namespace gatcore
