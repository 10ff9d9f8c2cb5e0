#include "src/ops/op_util.hpp"

namespace gatcore::ops_detail {

void check_var(const char* op, const char* arg, const Var& v) {
  GATCORE_CHECK(v.defined(), op, ": ", arg, " is undefined");
}

void check_same_shape(const char* op, const char* a_name, const Tensor& a, const char* b_name, const Tensor& b) {
  GATCORE_CHECK(a.same_shape(b), op, ": ", a_name, " ", a.shape_str(), " and ", b_name, " ", b.shape_str(),
                " must have the same shape");
}

Backend& backend_of(const char* op, std::initializer_list<const Var*> inputs) {
  const Var* first = nullptr;
  for (const Var* v : inputs) {
    if (!v || !v->defined()) continue;
    if (!first) first = v;
    else
      GATCORE_CHECK(v->device() == first->device(), op, ": inputs live on different devices (",
                    device_name(first->device()), " and ", device_name(v->device()),
                    "); move them with to(device) first");
  }
  GATCORE_CHECK(first != nullptr, op, ": no defined input");
  return backend(first->device());
}

Var make_output(const char* op, Backend& be, std::int64_t rows, std::int64_t cols, const Var& into, bool grad) {
  if (into.defined()) {
    GATCORE_CHECK(into.rows() == rows && into.cols() == cols, op, ": `into` has shape ", into.value().shape_str(),
                  ", the result is [", rows, ", ", cols, "]");
    GATCORE_CHECK(into.device() == be.device(), op, ": `into` lives on ", device_name(into.device()));
    if (grad) {
      into.set_requires_grad(true);
      // The buffer a slot belongs to carries the gradient of all its slots.
      if (into.impl()->base) into.impl()->base->requires_grad = true;
    }
    return into;
  }
  return Var(be.empty(rows, cols), grad);
}

}  // namespace gatcore::ops_detail
