#pragma once
// Tape-based reverse-mode autodiff.
//
// A Var is a shared handle to a value tensor, its gradient and a flag saying
// whether gradients are wanted. Differentiable ops (ops.hpp) compute their
// result through the Backend of the inputs' device and, when gradients are
// enabled and some input requires them, append a backward closure to the
// current thread's tape. backward(loss) runs the tape once in reverse and
// then clears it. Saved tensors remember the storage version they were saved
// at; if it changed by backward time (an in-place write), backward throws
// AutogradError rather than computing garbage.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "gatcore/tensor.hpp"

namespace gatcore {

struct VarImpl {
  Tensor value;
  Tensor grad;  // undefined until a gradient arrives (own grad; unused for views)
  bool requires_grad = false;
  std::string name;
  // A slice view of another Var: its gradient is the same slice of the base's
  // gradient, so writes of a DenseNet block into its slot and reads of the
  // prefix by later blocks all meet in one gradient buffer (column slices),
  // and the row blocks of one weight used by two products accumulate into
  // that weight's gradient (row slices).
  std::shared_ptr<VarImpl> base;
  std::int64_t row0 = 0, col0 = 0;

  // The gradient if any has arrived, else an undefined tensor.
  Tensor grad_if_any() const;
  // The gradient, allocated as zeros on first use.
  Tensor grad_or_zeros();
};

class Var {
 public:
  Var() = default;
  explicit Var(Tensor value, bool requires_grad = false, std::string name = {});
  static Var parameter(Tensor value, std::string name) { return Var(std::move(value), true, std::move(name)); }

  bool defined() const { return impl_ != nullptr; }
  const Tensor& value() const { return impl_->value; }
  std::int64_t rows() const { return impl_->value.rows(); }
  std::int64_t cols() const { return impl_->value.cols(); }
  Device device() const { return impl_->value.device(); }
  bool requires_grad() const { return impl_ && impl_->requires_grad; }
  void set_requires_grad(bool r) const { impl_->requires_grad = r; }
  const std::string& name() const { return impl_->name; }
  void set_name(std::string n) const { impl_->name = std::move(n); }

  Tensor grad() const { return impl_->grad_if_any(); }
  Tensor grad_or_zeros() const { return impl_->grad_or_zeros(); }
  void zero_grad() const;  // drops the gradient (next backward starts from zero)

  // Differentiable column slice [c0, c1) / row slice [r0, r1): views sharing
  // value and gradient.
  Var cols_slice(std::int64_t c0, std::int64_t c1) const;
  Var rows_slice(std::int64_t r0, std::int64_t r1) const;

  const std::shared_ptr<VarImpl>& impl() const { return impl_; }

 private:
  // A view of `value` (a slice of this Var's value at rows r0.., columns c0..).
  Var view(Tensor value, std::int64_t r0, std::int64_t c0) const;
  std::shared_ptr<VarImpl> impl_;
};

// A tensor saved for backward together with its version at save time.
class SavedTensor {
 public:
  SavedTensor() = default;
  SavedTensor(Tensor t, const char* what) : t_(std::move(t)), version_(t_.version()), what_(what) {}
  // Throws AutogradError naming the op and the tensor if it was modified in place.
  const Tensor& get(const char* op) const;

 private:
  Tensor t_;
  std::uint64_t version_ = 0;
  const char* what_ = "";
};

class Tape {
 public:
  void record(const char* op, std::function<void()> backward);
  // Seeds d loss = 1 (loss must be [1, 1]), runs every recorded closure in
  // reverse order, then clears the tape (also if a closure throws).
  void backward(const Var& loss);
  void clear() { nodes_.clear(); }
  std::size_t size() const { return nodes_.size(); }

 private:
  struct Node {
    const char* op;
    std::function<void()> backward;
  };
  std::vector<Node> nodes_;
};

// The calling thread's tape.
Tape& current_tape();
inline void backward(const Var& loss) { current_tape().backward(loss); }

// Gradient recording on / off for the calling thread.
bool grad_enabled();
class NoGradGuard {
 public:
  NoGradGuard();
  ~NoGradGuard();
  NoGradGuard(const NoGradGuard&) = delete;
  NoGradGuard& operator=(const NoGradGuard&) = delete;

 private:
  bool prev_;
};

// True when an op on these inputs must record a backward closure.
bool needs_grad(std::initializer_list<const Var*> inputs);

}  // namespace gatcore
