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

}  // namespace gatcore::character
