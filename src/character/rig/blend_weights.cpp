#include "gatcore/character/rig/blend_weights.hpp"

#include <cmath>
#include <map>

#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

SkinWeights blend_weights(const SkinWeights& a, const SkinWeights& b, float share, int max_influences) {
  GATCORE_CHECK(a.num_vertices() == b.num_vertices(), "blend_weights: the two weight sets have ", a.num_vertices(),
                " and ", b.num_vertices(), " vertices");
  GATCORE_CHECK(std::isfinite(share) && share >= 0.0f && share <= 1.0f, "blend_weights: share must be in [0, 1], got ",
                share);
  // A joint listed twice in one row (not produced by gatcore, but legal in a
  // file) adds up, as skinning would.
  SkinWeights mixed;
  std::map<std::int32_t, double> row;
  for (std::int64_t v = 0; v < a.num_vertices(); ++v) {
    row.clear();
    for (std::int64_t k = a.ptr[v]; k < a.ptr[v + 1]; ++k) row[a.joint[k]] += (1.0 - share) * double(a.weight[k]);
    for (std::int64_t k = b.ptr[v]; k < b.ptr[v + 1]; ++k) row[b.joint[k]] += double(share) * double(b.weight[k]);
    for (const auto& [j, x] : row) {
      mixed.joint.push_back(j);
      mixed.weight.push_back(static_cast<float>(x));
    }
    mixed.ptr.push_back(static_cast<std::int64_t>(mixed.joint.size()));
  }
  return limit_weights(mixed, max_influences);
}

}  // namespace gatcore::character
