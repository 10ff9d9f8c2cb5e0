#pragma once
// The rig's own bone-axis convention: which signed local axis of a joint's
// bind frame points along its bone (Blender and FBX2glTF: +Y; many FBX rigs:
// +X). Found by vote over the joints with exactly one child (the axis that
// best points from the joint to that child). A leaf joint has no child to
// point at; its bone follows this axis of its own frame, which is how a foot
// without toe joints still points forwards rather than down its shin.
#include <cstdint>

#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

struct BoneAxis {
  int axis = -1;  // 0 = X, 1 = Y, 2 = Z; -1: no joint has one child (no vote)
  int sign = 0;   // +1 or -1
};
BoneAxis bone_axis_convention(const Skeleton& s);

// Unit direction of joint j's bone in the bind frame: towards its first
// child, else (a leaf) along the convention's axis of its own bind frame,
// else continuing its parent's direction; {0, 0, 0} for a lone joint.
Vec3 bone_direction(const Skeleton& s, std::int32_t j, const BoneAxis& convention);

}  // namespace gatcore::character
