#include "gatcore/autograd.hpp"

#include "gatcore/backend.hpp"

namespace gatcore {

Tensor VarImpl::grad_if_any() const {
  if (base) {
    Tensor bg = base->grad_if_any();
    return bg.defined() ? bg.rows_slice(row0, row0 + value.rows()).cols_slice(col0, col0 + value.cols()) : Tensor{};
  }
  return grad;
}

Tensor VarImpl::grad_or_zeros() {
  if (base) return base->grad_or_zeros().rows_slice(row0, row0 + value.rows()).cols_slice(col0, col0 + value.cols());
  if (!grad.defined()) grad = backend(value.device()).zeros(value.rows(), value.cols());
  return grad;
}

Var::Var(Tensor value, bool requires_grad, std::string name) : impl_(std::make_shared<VarImpl>()) {
  GATCORE_CHECK(value.defined(), "Var: value tensor is undefined");
  impl_->value = std::move(value);
  impl_->requires_grad = requires_grad;
  impl_->name = std::move(name);
}

void Var::zero_grad() const {
  if (impl_->base) {
    // A view's gradient is part of its base's: clear just the slice.
    Tensor g = impl_->grad_if_any();
    if (g.defined()) backend(g.device()).fill(g, 0.0f);
  } else {
    impl_->grad = Tensor{};
  }
}

Var Var::cols_slice(std::int64_t c0, std::int64_t c1) const {
  Var v = view(impl_->value.cols_slice(c0, c1), 0, c0);
  v.impl_->name = impl_->name.empty() ? std::string{} : impl_->name + detail::cat("[:,", c0, ":", c1, "]");
  return v;
}

Var Var::rows_slice(std::int64_t r0, std::int64_t r1) const {
  Var v = view(impl_->value.rows_slice(r0, r1), r0, 0);
  v.impl_->name = impl_->name.empty() ? std::string{} : impl_->name + detail::cat("[", r0, ":", r1, ",:]");
  return v;
}

Var Var::view(Tensor value, std::int64_t r0, std::int64_t c0) const {
  Var v;
  v.impl_ = std::make_shared<VarImpl>();
  v.impl_->value = std::move(value);
  v.impl_->requires_grad = impl_->requires_grad;
  // Views of views point at the root so gradients meet in one buffer.
  v.impl_->base = impl_->base ? impl_->base : impl_;
  v.impl_->row0 = (impl_->base ? impl_->row0 : 0) + r0;
  v.impl_->col0 = (impl_->base ? impl_->col0 : 0) + c0;
  return v;
}

const Tensor& SavedTensor::get(const char* op) const {
  if (t_.defined() && t_.version() != version_)
    throw AutogradError(detail::cat("backward of '", op, "': saved tensor '", what_, "' ", t_.shape_str(),
                                    " was modified in place after it was saved (version ", version_, " -> ",
                                    t_.version(), "); clone it before modifying, or modify it after backward()"));
  return t_;
}

void Tape::record(const char* op, std::function<void()> backward) {
  nodes_.push_back(Node{op, std::move(backward)});
}

void Tape::backward(const Var& loss) {
  struct ClearOnExit {
    Tape* t;
    ~ClearOnExit() { t->clear(); }
  } clear_on_exit{this};
  GATCORE_CHECK(loss.defined(), "backward: loss is undefined");
  GATCORE_CHECK(loss.rows() == 1 && loss.cols() == 1, "backward: loss must be a [1, 1] scalar, got ",
                loss.value().shape_str());
  GATCORE_CHECK(loss.requires_grad(), "backward: loss does not require grad (no parameter reaches it, or it was "
                                      "computed under NoGradGuard)");
  Tensor seed = loss.impl()->grad_or_zeros();
  backend(seed.device()).fill(seed, 1.0f);
  NoGradGuard no_grad;  // closures must not record onto the tape they are sweeping
  for (auto it = nodes_.rbegin(); it != nodes_.rend(); ++it) {
    try {
      it->backward();
      // Drop the closure now: it holds the op's saved tensors and its output
      // (whose gradient every consumer, all later on the tape, has already
      // delivered), so memory is released as the sweep goes instead of all
      // at once at the end; that roughly halves a training step's peak.
      it->backward = nullptr;
    } catch (const AutogradError&) {
      throw;
    } catch (const std::exception& e) {
      throw AutogradError(detail::cat("backward of '", it->op, "': ", e.what()));
    }
  }
}

Tape& current_tape() {
  thread_local Tape tape;
  return tape;
}

namespace {
thread_local bool g_grad_enabled = true;
}

bool grad_enabled() { return g_grad_enabled; }
NoGradGuard::NoGradGuard() : prev_(g_grad_enabled) { g_grad_enabled = false; }
NoGradGuard::~NoGradGuard() { g_grad_enabled = prev_; }

bool needs_grad(std::initializer_list<const Var*> inputs) {
  if (!g_grad_enabled) return false;
  for (const Var* v : inputs)
    if (v && v->defined() && v->requires_grad()) return true;
  return false;
}

}  // namespace gatcore
