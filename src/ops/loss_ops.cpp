// Reductions and losses: [1, 1] results that stay on the device.
#include "src/ops/op_util.hpp"

namespace gatcore {
using namespace ops_detail;

namespace {
Var scaled_sum(const char* op, const Var& x, float s) {
  check_var(op, "x", x);
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y(be.empty(1, 1), grad);
  be.sum_all(x.value(), y.value());
  if (s != 1.0f) be.axpby(s, y.value(), 0.0f, y.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, s, xi = x.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.add_scalar_accumulate(dy, s, xi->grad_or_zeros());
    });
  return y;
}

void check_target(const char* op, const Var& pred, const Tensor& target) {
  check_var(op, "pred", pred);
  GATCORE_CHECK(target.defined(), op, ": target is undefined");
  check_same_shape(op, "pred", pred.value(), "target", target);
  GATCORE_CHECK(target.device() == pred.device(), op, ": target lives on ", device_name(target.device()),
                ", pred on ", device_name(pred.device()));
  GATCORE_CHECK(pred.value().numel() > 0, op, ": empty prediction");
}
}  // namespace

Var sum(const Var& x) { return scaled_sum("sum", x, 1.0f); }
Var mean(const Var& x) {
  GATCORE_CHECK(x.defined() && x.value().numel() > 0, "mean: empty input");
  return scaled_sum("mean", x, 1.0f / static_cast<float>(x.value().numel()));
}

Var mse_loss(const Var& pred, const Tensor& target) {
  static const char* op = "mse_loss";
  check_target(op, pred, target);
  Backend& be = backend_of(op, {&pred});
  const bool grad = needs_grad({&pred});
  Var y(be.empty(1, 1), grad);
  be.mse_forward(pred.value(), target, y.value());
  if (grad)
    current_tape().record(op, [&be, pi = pred.impl(), yi = y.impl(), ps = SavedTensor(pred.value(), "pred"),
                               ts = SavedTensor(target, "target")] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.mse_backward(ps.get(op), ts.get(op), dy, pi->grad_or_zeros());
    });
  return y;
}

Var kl_div_loss(const Var& pred, const Tensor& target, float eps) {
  static const char* op = "kl_div_loss";
  check_target(op, pred, target);
  Backend& be = backend_of(op, {&pred});
  const bool grad = needs_grad({&pred});
  Var y(be.empty(1, 1), grad);
  be.kl_div_forward(pred.value(), target, eps, y.value());
  if (grad)
    current_tape().record(op, [&be, eps, pi = pred.impl(), yi = y.impl(), ps = SavedTensor(pred.value(), "pred"),
                               ts = SavedTensor(target, "target")] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.kl_div_backward(ps.get(op), ts.get(op), eps, dy, pi->grad_or_zeros());
    });
  return y;
}

}  // namespace gatcore
