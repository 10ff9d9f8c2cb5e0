#pragma once
// NeuroSkinning's super skeleton: the union of the bones of several
// characters under semantic names, with a per-character bone mask.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "gatcore/character/rig/mesh.hpp"
#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

// Lower case; a namespace prefix ("mixamorig:", "Armature|") dropped; the
// side ("Left", "L_", ".L", "_l", "Right", ...) moved to a ".l" / ".r"
// suffix; separators (space . _ -) removed. "UpperArm.L" -> "upperarm.l",
// "LeftArm" -> "arm.l", "mixamorig:RightHand" -> "hand.r", "Spine_01" -> "spine01".
std::string normalise_bone_name(const std::string& name);

// Aliases: normalised name -> canonical normalised name, applied once after
// normalisation (not chained).
struct BoneAliases {
  std::vector<std::pair<std::string, std::string>> pairs;
  // The Quaternius modular women's fingers onto the men's (Index1.L is the
  // men's Index2.L, ...; the women's extra Thumb1 stays its own bone).
  static BoneAliases quaternius_women_to_men();
  std::string apply(const std::string& normalised) const;
};

struct SuperSkeleton {
  std::vector<std::string> names;                 // canonical bone names, in order of first appearance
  std::vector<std::vector<std::int32_t>> joint_to_bone;  // per character: joint -> super bone
  std::vector<std::vector<std::uint8_t>> mask;    // per character: [num bones] 1 if it has the bone

  std::int32_t num_bones() const { return static_cast<std::int32_t>(names.size()); }
};

// aliases: empty, or one BoneAliases per skeleton (applied to its names
// only). Throws InvalidArgument if two joints of one skeleton get the same name.
SuperSkeleton build_super_skeleton(const std::vector<const Skeleton*>& skeletons,
                                   const std::vector<BoneAliases>& aliases = {});

// A character's weights as dense [num_vertices x num_bones] super-skeleton weights.
std::vector<float> super_weights(const SkinWeights& w, const std::vector<std::int32_t>& joint_to_bone,
                                 std::int32_t num_bones);

}  // namespace gatcore::character
