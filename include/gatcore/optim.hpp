#pragma once
// Adam over a list of parameters. step() updates every parameter that has a
// gradient (in place: it bumps the parameter's version, so stepping between
// forward and backward is caught by the tape) and keeps its moments on the
// parameter's device.
#include <vector>

#include "gatcore/autograd.hpp"

namespace gatcore {

struct AdamOptions {
  float lr = 1e-3f;
  float beta1 = 0.9f;
  float beta2 = 0.999f;
  float eps = 1e-8f;
  float weight_decay = 0.0f;
};

class Adam {
 public:
  Adam(std::vector<Var> params, AdamOptions opt = {});
  void step();
  void zero_grad();
  float lr() const { return opt_.lr; }
  void set_lr(float lr) { opt_.lr = lr; }
  long steps() const { return step_; }
  const std::vector<Var>& params() const { return params_; }
  // Moments, exposed for checkpoints.
  std::vector<Tensor>& first_moments() { return m_; }
  std::vector<Tensor>& second_moments() { return v_; }
  void set_steps(long s) { step_ = s; }

 private:
  std::vector<Var> params_;
  std::vector<Tensor> m_, v_;
  AdamOptions opt_;
  long step_ = 0;
};

}  // namespace gatcore
