#include "gatcore/optim.hpp"

#include "gatcore/backend.hpp"

namespace gatcore {

Adam::Adam(std::vector<Var> params, AdamOptions opt) : params_(std::move(params)), opt_(opt) {
  for (std::size_t k = 0; k < params_.size(); ++k) {
    const Var& p = params_[k];
    GATCORE_CHECK(p.defined(), "Adam: parameter ", k, " is undefined");
    GATCORE_CHECK(p.requires_grad(), "Adam: parameter ", k, " ('", p.name(), "') does not require grad");
    Backend& be = backend(p.device());
    m_.push_back(be.zeros(p.rows(), p.cols()));
    v_.push_back(be.zeros(p.rows(), p.cols()));
  }
}

void Adam::step() {
  ++step_;
  for (std::size_t k = 0; k < params_.size(); ++k) {
    Tensor g = params_[k].grad();
    if (!g.defined()) continue;
    const Tensor& p = params_[k].value();
    backend(p.device())
        .adam_update(p, g, m_[k], v_[k], opt_.lr, opt_.beta1, opt_.beta2, opt_.eps, opt_.weight_decay, step_);
    p.bump_version();
  }
}

void Adam::zero_grad() {
  for (const Var& p : params_) p.zero_grad();
}

}  // namespace gatcore
