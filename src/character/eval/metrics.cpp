#include "gatcore/character/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "gatcore/error.hpp"

namespace gatcore::character {

DistanceStats vertex_distance_error(const std::vector<std::vector<float>>& predicted,
                                    const std::vector<std::vector<float>>& reference, double scale) {
  GATCORE_CHECK(predicted.size() == reference.size(), "vertex_distance_error: ", predicted.size(),
                " predicted frames, ", reference.size(), " reference frames");
  DistanceStats s;
  double sum = 0.0;
  for (std::size_t f = 0; f < predicted.size(); ++f) {
    const auto &a = predicted[f], &b = reference[f];
    GATCORE_CHECK(a.size() == b.size() && a.size() % 3 == 0, "vertex_distance_error: frame ", f, " has ", a.size(),
                  " predicted and ", b.size(), " reference coordinates");
    for (std::size_t v = 0; v < a.size() / 3; ++v) {
      const double dx = a[3 * v] - b[3 * v], dy = a[3 * v + 1] - b[3 * v + 1], dz = a[3 * v + 2] - b[3 * v + 2];
      const double d = std::sqrt(dx * dx + dy * dy + dz * dz) * scale;
      GATCORE_CHECK(std::isfinite(d), "vertex_distance_error: frame ", f, " vertex ", v, " is not finite");
      s.max = s.count ? std::max(s.max, d) : d;
      s.min = s.count ? std::min(s.min, d) : d;
      sum += d;
      ++s.count;
    }
  }
  s.mean = s.count ? sum / static_cast<double>(s.count) : 0.0;
  return s;
}

WeightMetrics weight_metrics(std::span<const float> predicted, std::span<const float> truth, std::int64_t bones,
                             double threshold, std::span<const std::uint8_t> mask) {
  GATCORE_CHECK(bones > 0 && predicted.size() == truth.size() && predicted.size() % bones == 0,
                "weight_metrics: ", predicted.size(), " predicted and ", truth.size(), " true weights for ", bones,
                " bones");
  GATCORE_CHECK(mask.empty() || static_cast<std::int64_t>(mask.size()) == bones, "weight_metrics: mask has ",
                mask.size(), " entries for ", bones, " bones");
  const std::int64_t n = static_cast<std::int64_t>(predicted.size()) / bones;
  std::int64_t tp = 0, pp = 0, tpos = 0;
  double l1_sum = 0.0, l1_max = 0.0;
  for (std::int64_t v = 0; v < n; ++v) {
    double l1 = 0.0;
    for (std::int64_t b = 0; b < bones; ++b) {
      if (!mask.empty() && !mask[b]) continue;
      const float p = predicted[v * bones + b], t = truth[v * bones + b];
      const bool sp = p > threshold, st = t > 0.0f;
      pp += sp;
      tpos += st;
      tp += sp && st;
      l1 += std::abs(static_cast<double>(p) - t);
    }
    l1_sum += l1;
    l1_max = std::max(l1_max, l1);
  }
  WeightMetrics m;
  m.precision = pp ? static_cast<double>(tp) / static_cast<double>(pp) : 0.0;
  m.recall = tpos ? static_cast<double>(tp) / static_cast<double>(tpos) : 0.0;
  m.l1_mean = n ? l1_sum / static_cast<double>(n) : 0.0;
  m.l1_max = l1_max;
  return m;
}

DistanceStats worst_poses_error(const std::vector<std::vector<float>>& distances, double height, int worst) {
  GATCORE_CHECK(height > 0.0, "worst_poses_error: height must be positive, got ", height);
  GATCORE_CHECK(worst >= 1, "worst_poses_error: worst must be >= 1, got ", worst);
  std::vector<double> mean(distances.size(), 0.0);
  for (std::size_t p = 0; p < distances.size(); ++p) {
    for (float d : distances[p]) mean[p] += d;
    if (!distances[p].empty()) mean[p] /= static_cast<double>(distances[p].size());
  }
  std::vector<std::size_t> order(distances.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return mean[a] > mean[b]; });
  DistanceStats s;
  double sum = 0.0;
  for (std::size_t k = 0; k < order.size() && k < static_cast<std::size_t>(worst); ++k)
    for (float d : distances[order[k]]) {
      s.max = s.count ? std::max<double>(s.max, d) : d;
      s.min = s.count ? std::min<double>(s.min, d) : d;
      sum += d;
      ++s.count;
    }
  s.mean = s.count ? sum / static_cast<double>(s.count) / height : 0.0;
  s.max /= height;
  s.min /= height;
  return s;
}

}  // namespace gatcore::character
