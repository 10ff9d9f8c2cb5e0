#include "gatcore/character/rig/skeleton.hpp"

#include "gatcore/error.hpp"

namespace gatcore::character {

std::int32_t Skeleton::find(const std::string& name) const {
  for (std::int32_t j = 0; j < num_joints(); ++j)
    if (names[j] == name) return j;
  return -1;
}

std::vector<std::vector<std::int32_t>> Skeleton::children() const {
  std::vector<std::vector<std::int32_t>> c(names.size());
  for (std::int32_t j = 0; j < num_joints(); ++j)
    if (parents[j] >= 0) c[parents[j]].push_back(j);
  return c;
}

void Skeleton::validate(const char* what) const {
  const std::size_t n = names.size();
  GATCORE_CHECK(parents.size() == n && rest_local.size() == n && inverse_bind.size() == n && root_parent.size() == n,
                what, ": per-joint arrays have different sizes");
  for (std::size_t j = 0; j < n; ++j) {
    GATCORE_CHECK(parents[j] >= -1 && parents[j] < static_cast<std::int32_t>(j), what, ": joint ", j, " ('",
                  names[j], "') has parent ", parents[j], " (parents must come first)");
    for (float x : inverse_bind[j])
      GATCORE_CHECK(std::isfinite(x), what, ": joint '", names[j], "' has a non-finite inverse bind matrix");
  }
}

}  // namespace gatcore::character
