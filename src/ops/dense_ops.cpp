// Dense and pointwise differentiable ops.
#include "src/ops/op_util.hpp"

namespace gatcore {
namespace ops_detail {

void linear_product(Backend& be, Precision p, const Tensor& x, const Tensor& W, const Tensor& y) {
  product(be, p, x, false, W, false, y, 1.0f, 0.0f);
}
void linear_input_grad(Backend& be, Precision p, const Tensor& dy, const Tensor& W, const Tensor& dx, float beta) {
  product(be, p, dy, false, W, true, dx, 1.0f, beta);
}
void linear_weight_grad(Backend& be, Precision p, const Tensor& x, const Tensor& dy, const Tensor& dW, float beta) {
  product(be, p, x, true, dy, false, dW, 1.0f, beta);
}

BatchNormSetup batch_norm_setup(const char* op, const Var& x, const Var& gamma, const Var& beta, BatchNormState& st,
                                bool training) {
  check_var(op, "x", x);
  check_var(op, "gamma", gamma);
  check_var(op, "beta", beta);
  const std::int64_t C = x.cols();
  GATCORE_CHECK(gamma.rows() == 1 && gamma.cols() == C && beta.rows() == 1 && beta.cols() == C, op,
                ": gamma ", gamma.value().shape_str(), " and beta ", beta.value().shape_str(), " must be [1, ", C,
                "]");
  BatchNormSetup s;
  s.be = &backend_of(op, {&x, &gamma, &beta});
  if (!st.running_mean.defined()) {
    st.running_mean = s.be->zeros(1, C);
    st.running_var = s.be->empty(1, C);
    s.be->fill(st.running_var, 1.0f);
  }
  GATCORE_CHECK(st.running_mean.cols() == C && st.running_var.cols() == C, op, ": running statistics have ",
                st.running_mean.cols(), " columns, x has ", C);
  // A batch split over processes (batch_split.hpp): SyncBatchNorm, the
  // statistics summed over the processes (a placeholder share adds zeros).
  const BatchSplit* split = training ? current_batch_split() : nullptr;
  if (split) {
    s.placeholder = split->placeholder();
    s.across = [sum = split->sum, placeholder = s.placeholder](double* v, std::size_t n) {
      if (placeholder) std::fill(v, v + n, 0.0);
      sum(v, n);
    };
  }
  if (training && !split)
    GATCORE_CHECK(x.rows() > 1, op, ": training needs more than one row to estimate a variance");
  return s;
}

}  // namespace ops_detail

using namespace ops_detail;

Var matmul(const Var& a, const Var& b, const Var& into) {
  return linear(a, b, Var{}, into);
}

Var linear(const Var& x, const Var& W, const Var& b, const Var& into) {
  static const char* op = "linear";
  check_var(op, "x", x);
  check_var(op, "W", W);
  GATCORE_CHECK(x.cols() == W.rows(), op, ": x ", x.value().shape_str(), " does not match W ",
                W.value().shape_str(), " (x.cols must equal W.rows)");
  if (b.defined())
    GATCORE_CHECK(b.rows() == 1 && b.cols() == W.cols(), op, ": bias ", b.value().shape_str(),
                  " must be [1, ", W.cols(), "]");
  Backend& be = backend_of(op, {&x, &W, &b});
  const bool grad = needs_grad({&x, &W, &b});
  Var y = make_output(op, be, x.rows(), W.cols(), into, grad);
  const Precision prec = product_precision(be, x.cols());
  linear_product(be, prec, x.value(), W.value(), y.value());
  if (b.defined()) be.add_row_bias(b.value(), y.value());
  if (grad) {
    current_tape().record(op, [&be, prec, xi = impl_if(x), Wi = impl_if(W), bi = impl_if(b), yi = y.impl(),
                               xs = SavedTensor(x.value(), "x"), Ws = SavedTensor(W.value(), "W")] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      accumulate_grad(be, xi,
                      [&](const Tensor& dx, float beta) { linear_input_grad(be, prec, dy, Ws.get(op), dx, beta); });
      accumulate_grad(be, Wi,
                      [&](const Tensor& dW, float beta) { linear_weight_grad(be, prec, xs.get(op), dy, dW, beta); });
      if (bi && bi->requires_grad) be.column_sums_accumulate(dy, bi->grad_or_zeros());
    });
  }
  return y;
}

namespace {
// y = alpha*a + beta*b with gradients alpha*dy, beta*dy.
Var linear_combination(const char* op, float alpha, const Var& a, float beta, const Var& b, const Var& into) {
  check_var(op, "a", a);
  check_var(op, "b", b);
  check_same_shape(op, "a", a.value(), "b", b.value());
  Backend& be = backend_of(op, {&a, &b});
  const bool grad = needs_grad({&a, &b});
  Var y = make_output(op, be, a.rows(), a.cols(), into, grad);
  be.axpby(alpha, a.value(), beta, b.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, alpha, beta, ai = a.impl(), bi = b.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      if (ai->requires_grad) be.axpy(alpha, dy, ai->grad_or_zeros());
      if (bi->requires_grad) be.axpy(beta, dy, bi->grad_or_zeros());
    });
  return y;
}
}  // namespace

Var add(const Var& a, const Var& b, const Var& into) { return linear_combination("add", 1.0f, a, 1.0f, b, into); }
Var sub(const Var& a, const Var& b) { return linear_combination("sub", 1.0f, a, -1.0f, b, Var{}); }

Var scale(const Var& a, float s) {
  static const char* op = "scale";
  check_var(op, "a", a);
  Backend& be = backend_of(op, {&a});
  const bool grad = needs_grad({&a});
  Var y = make_output(op, be, a.rows(), a.cols(), Var{}, grad);
  be.axpby(s, a.value(), 0.0f, a.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, s, ai = a.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.axpy(s, dy, ai->grad_or_zeros());
    });
  return y;
}

Var mul(const Var& a, const Var& b) {
  static const char* op = "mul";
  check_var(op, "a", a);
  check_var(op, "b", b);
  check_same_shape(op, "a", a.value(), "b", b.value());
  Backend& be = backend_of(op, {&a, &b});
  const bool grad = needs_grad({&a, &b});
  Var y = make_output(op, be, a.rows(), a.cols(), Var{}, grad);
  be.mul(a.value(), b.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, ai = a.impl(), bi = b.impl(), yi = y.impl(),
                               as = SavedTensor(a.value(), "a"), bs = SavedTensor(b.value(), "b")] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      if (ai->requires_grad) be.mul_accumulate(bs.get(op), dy, ai->grad_or_zeros());
      if (bi->requires_grad) be.mul_accumulate(as.get(op), dy, bi->grad_or_zeros());
    });
  return y;
}

Var concat(const std::vector<Var>& parts) {
  static const char* op = "concat";
  GATCORE_CHECK(!parts.empty(), op, ": no parts");
  std::int64_t cols = 0;
  bool grad = false;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    check_var(op, "part", parts[k]);
    GATCORE_CHECK(parts[k].rows() == parts[0].rows(), op, ": part ", k, " has ", parts[k].rows(),
                  " rows, part 0 has ", parts[0].rows());
    GATCORE_CHECK(parts[k].device() == parts[0].device(), op, ": part ", k, " lives on ",
                  device_name(parts[k].device()), ", part 0 on ", device_name(parts[0].device()));
    cols += parts[k].cols();
    grad |= needs_grad({&parts[k]});
  }
  Backend& be = backend(parts[0].device());
  Var y = make_output(op, be, parts[0].rows(), cols, Var{}, grad);
  std::vector<ImplPtr> impls;
  std::int64_t c0 = 0;
  for (const Var& p : parts) {
    be.copy(p.value(), y.value().cols_slice(c0, c0 + p.cols()));
    c0 += p.cols();
    impls.push_back(p.impl());
  }
  if (grad)
    current_tape().record(op, [&be, impls = std::move(impls), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      std::int64_t c = 0;
      for (const ImplPtr& p : impls) {
        const std::int64_t w = p->value.cols();
        if (p->requires_grad) be.axpy(1.0f, dy.cols_slice(c, c + w), p->grad_or_zeros());
        c += w;
      }
    });
  return y;
}

Var copy_into(const Var& src, const Var& into) {
  static const char* op = "copy_into";
  check_var(op, "src", src);
  check_var(op, "into", into);
  Backend& be = backend_of(op, {&src, &into});
  const bool grad = needs_grad({&src});
  Var y = make_output(op, be, src.rows(), src.cols(), into, grad);
  be.copy(src.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, si = src.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.axpy(1.0f, dy, si->grad_or_zeros());
    });
  return y;
}

Var activation(Activation f, const Var& x, float slope, const Var& into) {
  const char* op = activation_name(f);
  check_var(op, "x", x);
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y = make_output(op, be, x.rows(), x.cols(), into, grad);
  be.activation_forward(f, x.value(), y.value(), slope);
  if (grad)
    current_tape().record(op, [&be, f, slope, op, xi = x.impl(), yi = y.impl(), xs = SavedTensor(x.value(), "x"),
                               ys = SavedTensor(y.value(), "y")] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      const GradTarget dx = grad_target(be, xi);
      be.activation_backward(f, xs.get(op), ys.get(op), dy, dx.grad, slope, dx.accumulate);
    });
  return y;
}

Var row_softmax(const Var& x, const Tensor& mask) {
  static const char* op = "row_softmax";
  check_var(op, "x", x);
  if (mask.defined())
    GATCORE_CHECK(mask.rows() == 1 && mask.cols() == x.cols(), op, ": mask ", mask.shape_str(), " must be [1, ",
                  x.cols(), "]");
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y = make_output(op, be, x.rows(), x.cols(), Var{}, grad);
  be.row_softmax_forward(x.value(), mask, y.value());
  if (grad)
    current_tape().record(op, [&be, xi = x.impl(), yi = y.impl(), ys = SavedTensor(y.value(), "y")] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.row_softmax_backward(ys.get(op), dy, xi->grad_or_zeros());
    });
  return y;
}

Var batch_norm(const Var& x, const Var& gamma, const Var& beta, BatchNormState& st, bool training,
               const Var& into) {
  static const char* op = "batch_norm";
  const BatchNormSetup setup = batch_norm_setup(op, x, gamma, beta, st, training);
  Backend& be = *setup.be;
  const SumAcross& across = setup.across;
  const std::int64_t C = x.cols();
  const bool grad = needs_grad({&x, &gamma, &beta});
  Var y = make_output(op, be, x.rows(), C, into, grad);
  const float eps = st.eps;
  if (training) {
    Tensor mean = be.empty(1, C), invstd = be.empty(1, C);
    if (across)
      be.batchnorm_train_forward_across(x.value(), gamma.value(), beta.value(), eps, st.momentum, y.value(), mean,
                                        invstd, st.running_mean, st.running_var, across);
    else
      be.batchnorm_train_forward(x.value(), gamma.value(), beta.value(), eps, st.momentum, y.value(), mean, invstd,
                                 st.running_mean, st.running_var);
    if (grad)
      current_tape().record(op, [&be, across, placeholder = setup.placeholder, xi = x.impl(),
                                 gi = gamma.impl(), bi = beta.impl(), yi = y.impl(),
                                 xs = SavedTensor(x.value(), "x"), gs = SavedTensor(gamma.value(), "gamma"), mean,
                                 invstd] {
        Tensor dy = yi->grad_if_any();
        if (across) {
          // dy may not have arrived on this process (no loss reached it): zeros, the sums still happen.
          if (!dy.defined()) dy = be.zeros(xs.get(op).rows(), xs.get(op).cols());
          // A placeholder's rows are not in the batch: no gradient flows from them (the whole batch's
          // Σdy terms of d_x would otherwise make one up).
          be.batchnorm_train_backward_across(xs.get(op), gs.get(op), mean, invstd, dy,
                                             placeholder ? Tensor{} : grad_for(xi), grad_for(gi), grad_for(bi),
                                             across);
          return;
        }
        if (!dy.defined()) return;
        const GradTarget dx = grad_target(be, xi);
        be.batchnorm_train_backward(xs.get(op), gs.get(op), mean, invstd, dy, dx.grad, grad_for(gi), grad_for(bi),
                                    dx.accumulate);
      });
  } else {
    be.batchnorm_eval_forward(x.value(), gamma.value(), beta.value(), st.running_mean, st.running_var, eps,
                              y.value());
    if (grad)
      current_tape().record(op, [&be, eps, xi = x.impl(), gi = gamma.impl(), bi = beta.impl(), yi = y.impl(),
                                 xs = SavedTensor(x.value(), "x"), gs = SavedTensor(gamma.value(), "gamma"),
                                 rm = SavedTensor(st.running_mean, "running_mean"),
                                 rv = SavedTensor(st.running_var, "running_var")] {
        Tensor dy = yi->grad_if_any();
        if (!dy.defined()) return;
        be.batchnorm_eval_backward(xs.get(op), gs.get(op), rm.get(op), rv.get(op), eps, dy, grad_for(xi),
                                   grad_for(gi), grad_for(bi));
      });
  }
  return y;
}

}  // namespace gatcore
