#include "gatcore/models/sample.hpp"

#include <algorithm>
#include <cmath>

namespace gatcore::models {

Normaliser Normaliser::fit(const std::vector<Sample>& samples, bool scale_targets) {
  GATCORE_CHECK(!samples.empty(), "Normaliser::fit: no samples");
  const std::int64_t d = samples[0].features.cols();
  std::vector<double> s(std::size_t(d), 0.0), ss(std::size_t(d), 0.0);
  double count = 0, tss = 0, tcount = 0;
  for (const Sample& smp : samples) {
    GATCORE_CHECK(smp.features.cols() == d, "Normaliser::fit: sample '", smp.name, "' has ", smp.features.cols(),
                  " feature columns, expected ", d);
    for (std::int64_t i = 0; i < smp.features.rows(); ++i)
      for (std::int64_t j = 0; j < d; ++j) {
        const double v = smp.features.at(i, j);
        s[j] += v;
        ss[j] += v * v;
      }
    count += double(smp.features.rows());
    if (scale_targets && smp.target.defined())
      for (std::int64_t i = 0; i < smp.target.rows(); ++i)
        for (std::int64_t j = 0; j < smp.target.cols(); ++j) tss += double(smp.target.at(i, j)) * smp.target.at(i, j), ++tcount;
  }
  Normaliser n;
  n.mean = Tensor::empty(1, d);
  n.inv_std = Tensor::empty(1, d);
  for (std::int64_t j = 0; j < d; ++j) {
    const double m = s[j] / count, var = std::max(0.0, ss[j] / count - m * m);
    n.mean.at(0, j) = float(m);
    n.inv_std.at(0, j) = var > 1e-12 ? float(1.0 / std::sqrt(var)) : 0.f;  // constant in training: held there
  }
  if (scale_targets && tss > 0) n.target_scale = float(1.0 / std::sqrt(tss / tcount));
  return n;
}

Tensor Normaliser::apply(const Tensor& f) const {
  Tensor out = f.clone();
  if (!defined()) return out;
  check_shape(mean, 1, f.cols(), "normaliser mean");
  for (std::int64_t i = 0; i < f.rows(); ++i)
    for (std::int64_t j = 0; j < f.cols(); ++j) out.at(i, j) = (f.at(i, j) - mean.at(0, j)) * inv_std.at(0, j);
  return out;
}

}  // namespace gatcore::models
