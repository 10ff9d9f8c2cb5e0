#include "gatcore/character/deform/detail_distortion.hpp"

#include <algorithm>
#include <sstream>

#include "gatcore/error.hpp"

namespace gatcore::character {

void check_distortion_scales(std::span<const int> scales, std::string_view what) {
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
  std::vector<std::vector<float>> out(scales.size(), std::vector<float>(x.size()));
  std::vector<std::span<float>> spans(out.begin(), out.end());
  std::vector<float> smoothed(x.size()), scratch(x.size());
  laplacian_details(dm, x, scales, spans, smoothed, scratch);
  return out;
}

void laplacian_details(const DeltaMush& dm, std::span<const float> x, std::span<const int> scales,
                       std::span<const std::span<float>> out, std::span<float> s, std::span<float> scratch) {
  check_distortion_scales(scales, "laplacian_details");
  GATCORE_CHECK(out.size() == scales.size(), "laplacian_details: ", out.size(), " outputs for ", scales.size(),
                " scales");
  for (const std::span<float>& o : out)
    GATCORE_CHECK(o.size() == x.size(), "laplacian_details: an output of ", o.size(), " floats for ", x.size());
  GATCORE_CHECK(s.size() == x.size(), "laplacian_details: smoothing buffer of ", s.size(), " floats for ", x.size());
  // Smooth incrementally: S^k2 = S^(k2 - k1) S^k1.
  std::copy(x.begin(), x.end(), s.begin());
  int done = 0;
  for (std::size_t i = 0; i < scales.size(); ++i) {
    laplacian_smooth(dm, s, scales[i] - done, 0.5f, s, scratch);
    done = scales[i];
    const std::span<float>& d = out[i];
    for (std::size_t e = 0; e < d.size(); ++e) d[e] = x[e] - s[e];
  }
}

}  // namespace gatcore::character
