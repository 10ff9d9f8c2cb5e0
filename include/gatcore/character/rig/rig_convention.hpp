#pragma once
// Rig conventions: which joint-naming convention a skeleton follows (Mixamo,
// Unreal mannequin, Rigify, HumanIK, Biped, Daz, ...) and the map of its
// joints onto one canonical humanoid body. The names come from data tables
// (src/character/rig/rig_convention_tables.cpp); where names fail, a structural
// fallback (chain topology, left/right symmetry, rest positions) proposes the
// missing parts. Retargeting pairs source and target joints through this map.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/rig/skeleton.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"

namespace gatcore::character {

// Canonical body parts ("body names"): "pelvis", "spine1".."spineN" (from
// the pelvis up), "neck1".."neckM", "head", and per side (".l" / ".r"):
// "clavicle", "upperarm", "forearm", "hand", "thigh", "shin", "foot", "toe",
// "thumb1".."thumb3", "index1".."index3", "middle1".., "ring1".., "pinky1"..
// ("root" marks a joint above the pelvis that carries root motion.)
enum class JointRole : std::uint8_t {
  body,    // mapped onto a body part
  root,    // the rig's root above the pelvis
  helper,  // IK / pole / twist / roll / mechanism / end / socket bone: left alone, never a missing limb
  other,   // not recognised (eyes, jaw, tails, ears, props...)
};

struct RigMapping {
  std::string convention;        // e.g. "Mixamo", "Unreal mannequin (UE5)", "structural", "unknown"
  std::vector<std::string> body;  // per joint: its body part, or "" (see role)
  std::vector<JointRole> role;    // per joint
  std::vector<std::uint8_t> by_structure;  // per joint: 1 if the structural fallback proposed its part
  std::vector<std::string> missing;        // required humanoid parts not mapped (empty: a humanoid)

  bool humanoid() const { return missing.empty(); }
  std::int32_t find(const std::string& part) const;  // the joint mapped to `part`, -1 if none
};

// The parts a skeleton must have mapped for a humanoid retarget: pelvis,
// both thighs, shins, upper arms and forearms.
const std::vector<std::string>& required_humanoid_parts();
// Every body part name map_rig can produce (for --alias help and messages).
const std::vector<std::string>& body_part_names();
// The conventions the tables know, by the names map_rig reports.
std::vector<std::string> known_rig_conventions();

// Maps `s` onto the canonical body. aliases: normalised joint name (as
// normalise_bone_name gives) -> a body part ("thigh.l") or any joint name
// of a known convention ("LeftUpLeg", "UpperLeg.L"): applied first, so they
// override the tables and the structure. bind_to_world: where the skeleton's
// bind space sits in a Y-up world (the structural fallback reads up = +Y,
// the character's left = +X when it faces +Z).
RigMapping map_rig(const Skeleton& s, const BoneAliases& aliases = {}, const Mat4& bind_to_world = mat4_identity());

// Several lines: the convention, then every body part with its joint, then
// the helpers and the unrecognised joints; what `gat info` prints.
std::string describe_rig(const Skeleton& s, const RigMapping& m);

// The joints of `s` that are neither mapped nor helpers: what an --alias
// would have to name. At most `limit` names, then ", ...".
std::string unmapped_joint_list(const Skeleton& s, const RigMapping& m, std::size_t limit = 12);

}  // namespace gatcore::character
