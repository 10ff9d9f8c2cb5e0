#pragma once
// Finite differences of sum(R ⊙ forward) against backward through a whole
// model (training-mode BatchNorm, no dropout), for test_models and
// test_linear_skip: three random entries of every parameter, or every entry
// of the parameters `every_entry` selects.
#include <catch2/catch.hpp>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "gatcore/models/model.hpp"

namespace fixtures {

struct GradEntry {
  std::string param;
  std::int64_t row = 0, col = 0;
  double analytic = 0, numeric = 0;
};

inline std::vector<GradEntry> model_gradient_entries(gatcore::models::Model& m, const gatcore::models::Batch& b,
                                                     const std::function<bool(const std::string&)>& every_entry = {}) {
  using namespace gatcore;
  std::mt19937 rng(17);
  Var y = m.forward(b, true);
  Tensor R = Tensor::empty(y.rows(), y.cols());
  std::uniform_real_distribution<float> U(-1.f, 1.f);
  for (std::int64_t i = 0; i < R.rows(); ++i)
    for (std::int64_t j = 0; j < R.cols(); ++j) R.at(i, j) = U(rng);
  backward(sum(mul(y, Var(R))));
  auto value = [&] {
    NoGradGuard ng;
    Tensor v = m.forward(b, true).value();
    double s = 0;
    for (std::int64_t i = 0; i < v.rows(); ++i)
      for (std::int64_t j = 0; j < v.cols(); ++j) s += double(v.at(i, j)) * R.at(i, j);
    return s;
  };
  const float h = 1e-3f;
  std::vector<GradEntry> out;
  for (const auto& p : m.registry().params) {
    const Tensor& x = p.var.value();
    Tensor g = p.var.grad();
    REQUIRE(g.defined());
    const bool all = every_entry && every_entry(p.name);
    for (std::int64_t t = 0; t < (all ? x.numel() : 3); ++t) {
      const std::int64_t id = all ? t : std::int64_t(rng() % std::uint64_t(x.numel()));
      const std::int64_t r = id / x.cols(), c = id % x.cols();
      const float orig = x.at(r, c);
      x.at(r, c) = orig + h;
      const double lp = value();
      x.at(r, c) = orig - h;
      const double lm = value();
      x.at(r, c) = orig;
      out.push_back({p.name, r, c, g.at(r, c), (lp - lm) / (2.0 * h)});
    }
  }
  return out;
}

// float32 central differences through a deep net: allows rare kink hits
// (at most 1 in 20 entries off by more than 1e-2 + 5 % of the larger).
// Returns the entries for further checks.
inline std::vector<GradEntry> model_gradcheck(gatcore::models::Model& m, const gatcore::models::Batch& b,
                            const std::function<bool(const std::string&)>& every_entry = {}) {
  const std::vector<GradEntry> e = model_gradient_entries(m, b, every_entry);
  int bad = 0;
  for (const GradEntry& x : e)
    if (std::abs(x.analytic - x.numeric) > 1e-2 + 5e-2 * std::max(std::abs(x.analytic), std::abs(x.numeric))) {
      ++bad;
      UNSCOPED_INFO(x.param << " (" << x.row << ", " << x.col << "): analytic " << x.analytic << " vs fd " << x.numeric);
    }
  CHECK(bad <= int(e.size()) / 20);
  return e;
}

}  // namespace fixtures
