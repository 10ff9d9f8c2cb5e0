#include "gatcore/character/deform/detail_distortion.hpp"

#include <sstream>

#include "gatcore/error.hpp"

namespace gatcore::character {

void check_distortion_scales(std::span<const int> scales, const std::string& what) {
  for (std::size_t i = 0; i < scales.size(); ++i) {
    GATCORE_CHECK(scales[i] >= 1 && scales[i] <= 1000, what, ": distortion scale ", scales[i],
                  " is outside [1, 1000] smoothing steps");
    GATCORE_CHECK(i == 0 || scales[i] > scales[i - 1], what, ": distortion scales must be strictly increasing, got ",
                  scales[i - 1], " then ", scales[i]);
  }
}

std::vector<int> parse_distortion_scales(const std::string& text, const std::string& what) {
  std::vector<int> out;
  if (text.empty() || text == "none") return out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    std::size_t used = 0;
    int k = 0;
    try {
      k = std::stoi(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    GATCORE_CHECK(!item.empty() && used == item.size(), what, ": distortion scales must be a comma-separated list "
                  "of smoothing steps (e.g. 1,4,16) or 'none', got '", text, "'");
    out.push_back(k);
  }
  GATCORE_CHECK(text.back() != ',', what, ": distortion scales '", text, "' end with a comma");
  check_distortion_scales(out, what);
  return out;
}

std::string format_distortion_scales(std::span<const int> scales) {
  std::string s;
  for (int k : scales) {
    if (!s.empty()) s += ',';
    s += std::to_string(k);
  }
  return s;
}

std::vector<std::vector<float>> laplacian_details(const DeltaMush& dm, std::span<const float> x,
                                                  std::span<const int> scales) {
  check_distortion_scales(scales, "laplacian_details");
  std::vector<std::vector<float>> out;
  // Smooth incrementally: S^k2 = S^(k2 - k1) S^k1.
  std::vector<float> s(x.begin(), x.end());
  int done = 0;
  for (int k : scales) {
    s = laplacian_smooth(dm, s, k - done, 0.5f);
    done = k;
    std::vector<float> d(x.size());
    for (std::size_t i = 0; i < d.size(); ++i) d[i] = x[i] - s[i];
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace gatcore::character
