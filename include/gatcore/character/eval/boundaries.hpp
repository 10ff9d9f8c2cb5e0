#pragma once
// Where a humanoid's dominant bone goes wrong, per boundary that artists
// place by eye: head/neck, chest/neck, hips/spine, upper arm/chest, knee and
// ankle. Joints get a body region from their names and the hierarchy (any
// naming: "mixamorig:LeftUpLeg", "UpperLeg.L", "thigh_l"); a boundary is
// measured on the vertices whose artist's dominant joint lies on either side
// of it.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

enum class BodyRegion : std::uint8_t { other, head, neck, chest, spine, hips, upper_arm, upper_leg, lower_leg, foot };

// Per joint: head (a joint named head and everything under it), neck,
// chest (named chest / rib cage, or the neck's parent), spine (named spine /
// abdomen / torso / waist, or between the hips and the chest), hips (hips /
// pelvis), upper arm (upper arm, "LeftArm"; not fore- or lower arm), upper leg
// (thigh, up leg), lower leg (calf, shin, "LeftLeg"), foot (foot, ankle);
// other for the rest (shoulders, hands, toes, a creature's tail).
std::vector<BodyRegion> body_regions(const Skeleton& s);

enum class Boundary : std::uint8_t { head_neck, chest_neck, hips_spine, upper_arm_chest, knee, ankle };
inline constexpr std::array<Boundary, 6> kBoundaries{Boundary::head_neck,       Boundary::chest_neck,
                                                     Boundary::hips_spine,      Boundary::upper_arm_chest,
                                                     Boundary::knee,            Boundary::ankle};
const char* boundary_name(Boundary b);  // "head/neck", "chest/neck", ...

struct BoundaryConfusion {
  Boundary boundary = Boundary::head_neck;
  std::int64_t vertices = 0;  // artist's dominant joint on either side
  std::int64_t crossed = 0;   // of those, the prediction's dominant joint on the other side
};

// Dense [n x cols] weights; `column_region` gives each column's region. One
// entry per boundary with vertices on it (a skeleton without a neck has no
// head/neck boundary), in kBoundaries' order. Dominant joints as
// dominant_accuracy's (over `mask` when given).
std::vector<BoundaryConfusion> boundary_confusions(std::span<const float> predicted, std::span<const float> truth,
                                                   std::int64_t cols, std::span<const BodyRegion> column_region,
                                                   std::span<const std::uint8_t> mask = {});

}  // namespace gatcore::character
