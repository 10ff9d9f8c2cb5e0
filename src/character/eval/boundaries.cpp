#include "gatcore/character/eval/boundaries.hpp"

#include <cctype>
#include <string>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

// Lower case, letters and digits only, without a namespace prefix
// ("mixamorig:LeftUpLeg" -> "leftupleg").
std::string key(const std::string& name) {
  const std::size_t colon = name.rfind(':');
  std::string k;
  for (std::size_t i = colon == std::string::npos ? 0 : colon + 1; i < name.size(); ++i)
    if (std::isalnum(static_cast<unsigned char>(name[i]))) k += static_cast<char>(std::tolower(static_cast<unsigned char>(name[i])));
  return k;
}

bool has(const std::string& k, const char* part) { return k.find(part) != std::string::npos; }

BodyRegion by_name(const std::string& k) {
  if (has(k, "hips") || has(k, "pelvis") || k == "hip") return BodyRegion::hips;
  if (has(k, "head")) return BodyRegion::head;
  if (has(k, "neck")) return BodyRegion::neck;
  if (has(k, "chest") || has(k, "ribcage")) return BodyRegion::chest;
  if (has(k, "spine") || has(k, "abdomen") || has(k, "torso") || has(k, "waist")) return BodyRegion::spine;
  if (has(k, "forearm") || has(k, "lowerarm") || has(k, "armature")) return BodyRegion::other;
  if (has(k, "upperarm") || has(k, "uparm") || has(k, "arm")) return BodyRegion::upper_arm;
  if (has(k, "upperleg") || has(k, "upleg") || has(k, "thigh") || has(k, "femur")) return BodyRegion::upper_leg;
  if (has(k, "lowerleg") || has(k, "calf") || has(k, "shin") || has(k, "knee") || has(k, "leg"))
    return BodyRegion::lower_leg;
  if (has(k, "foot") || has(k, "ankle")) return BodyRegion::foot;
  return BodyRegion::other;
}

}  // namespace

std::vector<BodyRegion> body_regions(const Skeleton& s) {
  const std::int32_t nj = s.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(s.parents.size()) == nj, "body_regions: ", s.parents.size(),
                " parents for ", nj, " joints");
  std::vector<BodyRegion> r(static_cast<std::size_t>(nj));
  for (std::int32_t j = 0; j < nj; ++j) r[j] = by_name(key(s.names[j]));
  // Everything under the head is the head (jaw, eyes, a helmet joint);
  // parents come first.
  for (std::int32_t j = 0; j < nj; ++j)
    if (s.parents[j] >= 0 && r[s.parents[j]] == BodyRegion::head) r[j] = BodyRegion::head;
  // The neck's parent is the chest (a rig's "Spine2"), and the joints between
  // the hips and the chest are the spine.
  for (std::int32_t j = 0; j < nj; ++j) {
    const std::int32_t p = s.parents[j];
    if (r[j] != BodyRegion::neck || p < 0 || r[p] == BodyRegion::neck) continue;
    if (r[p] == BodyRegion::spine || r[p] == BodyRegion::other) r[p] = BodyRegion::chest;
    for (std::int32_t a = s.parents[p]; a >= 0 && r[a] != BodyRegion::hips; a = s.parents[a])
      if (r[a] == BodyRegion::other) r[a] = BodyRegion::spine;
  }
  return r;
}

const char* boundary_name(Boundary b) {
  switch (b) {
    case Boundary::head_neck: return "head/neck";
    case Boundary::chest_neck: return "chest/neck";
    case Boundary::hips_spine: return "hips/spine";
    case Boundary::upper_arm_chest: return "upper arm/chest";
    case Boundary::knee: return "knee";
    case Boundary::ankle: return "ankle";
  }
  return "?";
}

std::vector<BoundaryConfusion> boundary_confusions(std::span<const float> predicted, std::span<const float> truth,
                                                   std::int64_t cols, std::span<const BodyRegion> column_region,
                                                   std::span<const std::uint8_t> mask) {
  GATCORE_CHECK(cols > 0 && predicted.size() == truth.size() && predicted.size() % static_cast<std::size_t>(cols) == 0,
                "boundary_confusions: ", predicted.size(), " predicted and ", truth.size(), " true values for ", cols,
                " columns");
  GATCORE_CHECK(static_cast<std::int64_t>(column_region.size()) == cols, "boundary_confusions: ",
                column_region.size(), " column regions for ", cols, " columns");
  GATCORE_CHECK(mask.empty() || static_cast<std::int64_t>(mask.size()) == cols, "boundary_confusions: mask has ",
                mask.size(), " entries for ", cols, " columns");
  using R = BodyRegion;
  constexpr std::array<std::pair<R, R>, 6> sides{{{R::head, R::neck},
                                                  {R::chest, R::neck},
                                                  {R::hips, R::spine},
                                                  {R::upper_arm, R::chest},
                                                  {R::upper_leg, R::lower_leg},
                                                  {R::lower_leg, R::foot}}};
  std::array<BoundaryConfusion, 6> acc{};
  auto argmax = [&](std::span<const float> x, std::int64_t v) {
    std::int64_t best = -1;
    for (std::int64_t b = 0; b < cols; ++b) {
      if (!mask.empty() && !mask[static_cast<std::size_t>(b)]) continue;
      if (best < 0 || x[static_cast<std::size_t>(v * cols + b)] > x[static_cast<std::size_t>(v * cols + best)])
        best = b;
    }
    return best;
  };
  const std::int64_t n = static_cast<std::int64_t>(truth.size()) / cols;
  for (std::int64_t v = 0; v < n; ++v) {
    const std::int64_t t = argmax(truth, v), p = argmax(predicted, v);
    if (t < 0) continue;
    const R rt = column_region[static_cast<std::size_t>(t)], rp = column_region[static_cast<std::size_t>(p)];
    for (std::size_t b = 0; b < sides.size(); ++b) {
      const auto [x, y] = sides[b];
      if (rt != x && rt != y) continue;
      ++acc[b].vertices;
      acc[b].crossed += rp == (rt == x ? y : x);
    }
  }
  std::vector<BoundaryConfusion> out;
  for (std::size_t b = 0; b < sides.size(); ++b)
    if (acc[b].vertices > 0) {
      acc[b].boundary = kBoundaries[b];
      out.push_back(acc[b]);
    }
  return out;
}

}  // namespace gatcore::character
