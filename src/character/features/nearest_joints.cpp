#include "gatcore/character/features/nearest_joints.hpp"

#include <algorithm>
#include <charconv>

#include "gatcore/error.hpp"

namespace gatcore::character {

void nearest_joint_distances(const float* d, std::int64_t J, int K, float* out) {
  // Insertion into a sorted prefix: K is small (4-8) and J tens of joints.
  int have = 0;
  float farthest = d[0];
  for (std::int64_t j = 0; j < J; ++j) {
    const float x = d[j];
    farthest = std::max(farthest, x);
    if (have == K && x >= out[K - 1]) continue;
    int i = have < K ? have++ : K - 1;
    for (; i > 0 && out[i - 1] > x; --i) out[i] = out[i - 1];
    out[i] = x;
  }
  for (int i = have; i < K; ++i) out[i] = farthest;
}

Tensor nearest_joint_columns(const Tensor& f, int K) {
  GATCORE_CHECK(K >= 1 && K <= kMaxNearestJoints, "nearest_joint_columns: K must be in [1, ", kMaxNearestJoints,
                "], got ", K);
  GATCORE_CHECK(f.cols() > 6, "nearest_joint_columns: ", f.cols(), " columns: no joint distances (a skeleton with ",
                "no joints?)");
  const std::int64_t m = f.rows(), J = f.cols() - 6;
  Tensor out = Tensor::empty(m, 6 + K);
  for (std::int64_t i = 0; i < m; ++i) {
    const float* src = f.row(i);
    float* dst = out.row(i);
    std::copy_n(src, 6, dst);
    nearest_joint_distances(src + 6, J, K, dst + 6);
  }
  return out;
}

int parse_joint_columns(const std::string& text, const std::string& what) {
  if (text.empty() || text == "bones") return 0;
  const std::string prefix = "nearest:";
  int k = 0;
  const char* b = text.data() + prefix.size();
  const char* e = text.data() + text.size();
  const bool ok = text.rfind(prefix, 0) == 0 && text.size() > prefix.size() &&
                  std::from_chars(b, e, k).ptr == e && k >= 1 && k <= kMaxNearestJoints;
  GATCORE_CHECK(ok, what, ": expects 'bones' or 'nearest:K' with K in [1, ", kMaxNearestJoints, "], got '", text, "'");
  return k;
}

std::string format_joint_columns(int nearest) { return nearest > 0 ? "nearest:" + std::to_string(nearest) : "bones"; }

}  // namespace gatcore::character
