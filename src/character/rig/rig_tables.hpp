#pragma once
// Internal: the joint-name tables of the rig conventions map_rig knows
// (rig_convention_tables.cpp) and the structural fallback
// (rig_structure.cpp).
#include <string>
#include <vector>

#include "gatcore/character/rig/rig_convention.hpp"

namespace gatcore::character::rig_detail {

// One name of a convention. key: the joint name as rig_key() gives it
// (lower case, letters and digits only, namespace dropped), where '<' stands
// for "left" / "right" and '{' for "l" / "r". part: a body part, where '<'
// stands for ".l" / ".r"; chain parts ("spine", "neck", "thumb<", "index<",
// "middle<", "ring<", "pinky<") are numbered from the root outwards after
// mapping; "-" marks a helper (twist, roll, IK, end bone), "^" the root.
struct RigEntry {
  std::string key;
  std::string part;
};

struct RigTable {
  std::string name;
  std::vector<RigEntry> entries;    // sides expanded: keys are exact
  std::vector<std::string> signature;  // keys that tell this convention from look-alikes ("~x": raw name contains x)
};

const std::vector<RigTable>& rig_tables();

// Lower case, letters and digits only, after the last ':' or '|'; a 3ds Max
// "Bip001" / "Bip01" prefix becomes "bip01".
std::string rig_key(const std::string& name);

// Chain parts are numbered by depth after mapping: "spine", "neck" and the
// five fingers (per side).
bool is_chain_part(const std::string& part);

// Fills parts in `required_humanoid_parts()` (and the chain / hand / foot
// parts around them) that names did not give, from the skeleton's shape:
// world rest positions `pos`, up = +Y; the lateral axis is the line between
// the feet, the forward direction the toes' (else +Z), the character's left
// = up x forward. Only joints with role `other` are given parts; they are
// flagged in by_structure.
void propose_by_structure(const Skeleton& s, const std::vector<Vec3>& pos, RigMapping& m);

}  // namespace gatcore::character::rig_detail
