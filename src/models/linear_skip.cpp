#include "gatcore/models/linear_skip.hpp"

#include <Eigen/Dense>

#include "gatcore/error.hpp"

namespace gatcore::models {

LinearMap fit_linear_map(const std::vector<Sample>& samples, const Normaliser& norm, std::int64_t d, std::int64_t o,
                         double ridge) {
  GATCORE_CHECK(!samples.empty(), "fit_linear_map: no samples");
  GATCORE_CHECK(d > 0 && o > 0, "fit_linear_map: bad shape [", d, ", ", o, "]");
  GATCORE_CHECK(ridge >= 0, "fit_linear_map: ridge must be >= 0, got ", ridge);
  // Augmented with a constant column for the bias.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(d + 1, d + 1), B = Eigen::MatrixXd::Zero(d + 1, o);
  LinearMap fit;
  double tt = 0;
  Eigen::VectorXd row(d + 1);
  for (const Sample& s : samples) {
    GATCORE_CHECK(s.features.cols() == d && s.target.defined() && s.target.cols() == o &&
                      s.target.rows() == s.features.rows(),
                  "fit_linear_map: sample '", s.name, "' has ", s.features.cols(), " features / ",
                  s.target.defined() ? s.target.cols() : 0, " targets; the map takes ", d, " / ", o);
    const Tensor x = norm.defined() ? norm.apply(s.features) : s.features;
    for (std::int64_t i = 0; i < x.rows(); ++i) {
      for (std::int64_t c = 0; c < d; ++c) row[c] = x.at(i, c);
      row[d] = 1.0;
      A.selfadjointView<Eigen::Lower>().rankUpdate(row);
      for (std::int64_t k = 0; k < o; ++k) {
        const double t = double(s.target.at(i, k)) * norm.target_scale;
        B.col(Eigen::Index(k)) += row * t;
        tt += t * t;
      }
    }
    fit.rows += x.rows();
  }
  A.triangularView<Eigen::StrictlyUpper>() = A.transpose();
  const double lambda = ridge * A.diagonal().head(d).sum() / double(d);
  Eigen::MatrixXd R = A;
  for (std::int64_t c = 0; c < d; ++c) R(c, c) += lambda;
  const Eigen::MatrixXd X = R.ldlt().solve(B);
  GATCORE_CHECK(X.allFinite(), "fit_linear_map: the least-squares system is singular (constant samples?)");
  // Residual sum of squares from the normal equations: tᵀt − 2 XᵀB + XᵀAX.
  double rss = tt;
  for (std::int64_t k = 0; k < o; ++k) rss += -2.0 * X.col(k).dot(B.col(k)) + X.col(k).dot(A * X.col(k));
  const double count = double(fit.rows) * double(o);
  fit.mse_before = tt / count;
  fit.mse_after = std::max(0.0, rss / count);
  fit.W = Tensor::empty(d, o);
  fit.b = Tensor::empty(1, o);
  for (std::int64_t c = 0; c < d; ++c)
    for (std::int64_t k = 0; k < o; ++k) fit.W.at(c, k) = float(X(c, k));
  for (std::int64_t k = 0; k < o; ++k) fit.b.at(0, k) = float(X(d, k));
  return fit;
}

Tensor predict_linear(const LinearMap& map, const Sample& s, const Normaliser& norm) {
  GATCORE_CHECK(map.W.defined() && s.features.cols() == map.W.rows(), "predict_linear: sample '", s.name, "' has ",
                s.features.cols(), " features; the map takes ", map.W.defined() ? map.W.rows() : 0);
  const Tensor x = norm.defined() ? norm.apply(s.features) : s.features;
  const std::int64_t n = x.rows(), d = map.W.rows(), o = map.W.cols();
  Tensor y = Tensor::empty(n, o);
  const double inv = 1.0 / double(norm.target_scale);
  for (std::int64_t i = 0; i < n; ++i)
    for (std::int64_t k = 0; k < o; ++k) {
      double v = map.b.at(0, k);
      for (std::int64_t c = 0; c < d; ++c) v += double(x.at(i, c)) * map.W.at(c, k);
      y.at(i, k) = float(v * inv);
    }
  return y;
}

LinearMap fit_linear_skip(Model& model, const std::vector<Sample>& samples, const Normaliser& norm, double ridge) {
  const ModelConfig& cfg = model.config();
  GATCORE_CHECK(cfg.linear_skip, "fit_linear_skip: model '", cfg.name, "' has no linear skip (linear_skip = false)");
  const Var* W = model.registry().find_param("skip.W");
  const Var* b = model.registry().find_param("skip.b");
  GATCORE_CHECK(W && b, "fit_linear_skip: model '", cfg.name, "' lacks the skip.W / skip.b parameters");
  GATCORE_CHECK(W->device() == Device::cpu, "fit_linear_skip: the model's parameters must be on the CPU");
  LinearMap fit = fit_linear_map(samples, norm, cfg.in_dim, cfg.out_dim, ridge);
  W->value().copy_from_(fit.W);
  b->value().copy_from_(fit.b);
  return fit;
}

}  // namespace gatcore::models
