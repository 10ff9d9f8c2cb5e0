#pragma once
// Finite-difference gradient checking for the autodiff ops.
//
// L(x) = Σ R ⊙ f(x) with a fixed random R; the analytic dL/dx from backward()
// is compared with central differences (float32 forward, so the step and the
// tolerances are sized for single precision).
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "gatcore/autograd.hpp"
#include "gatcore/ops.hpp"

namespace gradcheck {

using gatcore::Tensor;
using gatcore::Var;

inline Tensor random_tensor(std::int64_t r, std::int64_t c, std::mt19937& rng, float lo = -1.f, float hi = 1.f) {
  std::uniform_real_distribution<float> U(lo, hi);
  Tensor t = Tensor::empty(r, c);
  for (std::int64_t i = 0; i < r; ++i)
    for (std::int64_t j = 0; j < c; ++j) t.at(i, j) = U(rng);
  return t;
}

struct Options {
  float step = 1e-2f;
  double rtol = 2e-2, atol = 2e-3;
  int max_entries = 48;  // per input, sampled
};

using Fn = std::function<Var(const std::vector<Var>&)>;

inline double loss_value(const Fn& f, const std::vector<Var>& in, const Tensor& R) {
  gatcore::NoGradGuard ng;
  Var y = f(in);
  double s = 0;
  for (std::int64_t i = 0; i < y.rows(); ++i)
    for (std::int64_t j = 0; j < y.cols(); ++j) s += double(y.value().at(i, j)) * R.at(i, j);
  return s;
}

// Checks every input flagged in `wants_grad` (default: all).
inline void check(const std::string& name, const Fn& f, std::vector<Tensor> inputs, Options opt = {},
                  std::vector<bool> wants_grad = {}) {
  INFO("gradcheck " << name);
  std::mt19937 rng(1234);
  if (wants_grad.empty()) wants_grad.assign(inputs.size(), true);
  std::vector<Var> vars;
  for (std::size_t k = 0; k < inputs.size(); ++k) vars.emplace_back(inputs[k], wants_grad[k]);
  Var y = f(vars);
  Tensor R = random_tensor(y.rows(), y.cols(), rng);
  Var loss = gatcore::sum(gatcore::mul(y, Var(R)));
  gatcore::backward(loss);
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    if (!wants_grad[k]) continue;
    Tensor g = vars[k].grad();
    REQUIRE(g.defined());
    Tensor x = vars[k].value();
    const std::int64_t n = x.numel();
    std::vector<std::int64_t> idx;
    if (n <= opt.max_entries) {
      for (std::int64_t i = 0; i < n; ++i) idx.push_back(i);
    } else {
      std::uniform_int_distribution<std::int64_t> U(0, n - 1);
      for (int i = 0; i < opt.max_entries; ++i) idx.push_back(U(rng));
    }
    for (std::int64_t id : idx) {
      const std::int64_t r = id / x.cols(), c = id % x.cols();
      const float orig = x.at(r, c);
      x.at(r, c) = orig + opt.step;
      const double lp = loss_value(f, vars, R);
      x.at(r, c) = orig - opt.step;
      const double lm = loss_value(f, vars, R);
      x.at(r, c) = orig;
      const double fd = (lp - lm) / (2.0 * opt.step);
      const double an = g.at(r, c);
      INFO("input " << k << " entry (" << r << ", " << c << "): analytic " << an << " vs finite difference " << fd);
      CHECK(std::abs(an - fd) <= opt.atol + opt.rtol * std::max(std::abs(an), std::abs(fd)));
    }
  }
}

}  // namespace gradcheck
