#include "gatcore/character/rig/limit_weights.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

void check_limits(int max_influences, float min_weight) {
  GATCORE_CHECK(max_influences >= 1, "limit_weights: max_influences must be >= 1, got ", max_influences);
  GATCORE_CHECK(std::isfinite(min_weight) && min_weight >= 0.0f && min_weight < 1.0f,
                "limit_weights: min_weight must be in [0, 1), got ", min_weight);
}

// row: (id, weight > 0). Keeps the largest max_influences, then drops those
// below min_weight of the kept total (never the largest), renormalises and
// sorts by id.
void limit_row(std::vector<std::pair<std::int32_t, float>>& row, int max_influences, float min_weight) {
  std::stable_sort(row.begin(), row.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  if (row.size() > static_cast<std::size_t>(max_influences)) row.resize(static_cast<std::size_t>(max_influences));
  double sum = 0;
  for (const auto& e : row) sum += e.second;
  std::size_t keep = 1;
  while (keep < row.size() && row[keep].second >= min_weight * sum) ++keep;
  row.resize(keep);
  sum = 0;
  for (const auto& e : row) sum += e.second;
  for (auto& e : row) e.second = static_cast<float>(e.second / sum);
  std::sort(row.begin(), row.end());
}

}  // namespace

SkinWeights limit_weights(const SkinWeights& w, int max_influences, float min_weight) {
  check_limits(max_influences, min_weight);
  SkinWeights out;
  std::vector<std::pair<std::int32_t, float>> row;
  for (std::int64_t v = 0; v < w.num_vertices(); ++v) {
    row.clear();
    for (std::int64_t k = w.ptr[v]; k < w.ptr[v + 1]; ++k)
      if (w.weight[k] > 0.0f) row.push_back({w.joint[k], w.weight[k]});
    GATCORE_CHECK(!row.empty(), "limit_weights: vertex ", v, " has no positive weight");
    limit_row(row, max_influences, min_weight);
    for (const auto& [j, x] : row) {
      out.joint.push_back(j);
      out.weight.push_back(x);
    }
    out.ptr.push_back(static_cast<std::int64_t>(out.joint.size()));
  }
  return out;
}

void limit_weights_dense(std::span<float> dense, std::int64_t cols, int max_influences, float min_weight,
                         std::span<const std::uint8_t> mask) {
  check_limits(max_influences, min_weight);
  GATCORE_CHECK(cols > 0 && dense.size() % static_cast<std::size_t>(cols) == 0, "limit_weights_dense: ",
                dense.size(), " values for ", cols, " columns");
  GATCORE_CHECK(mask.empty() || static_cast<std::int64_t>(mask.size()) == cols, "limit_weights_dense: mask has ",
                mask.size(), " entries for ", cols, " columns");
  const std::int64_t n = static_cast<std::int64_t>(dense.size()) / cols;
  std::vector<std::pair<std::int32_t, float>> row;
  for (std::int64_t v = 0; v < n; ++v) {
    float* r = dense.data() + v * cols;
    row.clear();
    for (std::int64_t b = 0; b < cols; ++b)
      if (r[b] > 0.0f && (mask.empty() || mask[static_cast<std::size_t>(b)]))
        row.push_back({static_cast<std::int32_t>(b), r[b]});
    std::fill(r, r + cols, 0.0f);
    if (row.empty()) continue;
    limit_row(row, max_influences, min_weight);
    for (const auto& [b, x] : row) r[b] = x;
  }
}

}  // namespace gatcore::character
