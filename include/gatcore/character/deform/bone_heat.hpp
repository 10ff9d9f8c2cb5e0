#pragma once
// Bone heat (Baran & Popovic 2007, "Automatic rigging and animation of 3D
// characters"; the method behind Blender's automatic weights): the weight of
// joint i is the equilibrium of heat diffusing over the mesh surface from the
// joint's bones,
//     (-Laplacian + H) w_i = H p_i,
// H_vv = c / d_v^2 with d_v the distance from vertex v to its nearest bone
// when v sees it (0 when it does not: the vertex only receives diffused heat;
// BoneHeatParams::nearest_only),
// p_i(v) = 1 when that bone is joint i's (split evenly among ties). The
// Laplacian is the cotangent one with lumped (barycentric) areas; one sparse
// LDLT factorisation per character, one solve per joint.
//
// Bones: joint j deforms the segments from its bind position to each child's;
// a leaf joint the segment along its own bone axis (the rig's convention,
// rig/bone_axis.hpp) for half the parent's length -- or, where a joint
// outside its chain sits on that axis within 1.5 parent lengths, up to that
// joint: glTF keeps no bone tails, and an IK foot target hanging off the root
// where the shin ends marks the shin's (a lone joint: its point). Positions come from the inverse
// bind matrices, so the mesh must be in the bind frame the skin uses (both the
// loaded and the world-frame prepared character are).
//
// Controls (joints that are not bones; used when `deforming` is empty): a
// root whose segments lie mostly outside the mesh (a root at the floor), and
// any joint whose own point is outside the mesh and farther than 5 % of the
// character's diagonal from its nearest vertex, with its segments mostly
// outside (an IK pole target, a "Body" hub above the back) -- unless such
// joints are most of the skeleton, which means the skeleton does not fit the
// mesh. A segment ending at a control is dropped too.
//
// Robustness for dressed, multi-mesh, non-manifold characters: vertices at the
// same position are welded for the diffusion (cracks between mesh pieces do not
// block heat), cotangents are clamped to [0, 1e3] (obtuse and degenerate
// triangles keep the system an M-matrix: weights stay in [0, 1]), and a mesh
// piece where no vertex sees a bone (a garment whose every ray to the bones
// crosses the body) is bound to its nearest bones regardless of visibility, so
// no vertex is left without weights.
#include <cstdint>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

struct BoneHeatParams {
  // c in H = c / d^2, against the standard cotangent Laplace-Beltrami
  // operator. Baran & Popovic's c = 1 is Blender's, but Blender's operator
  // is a quarter of the standard one (per triangle cot / (edge faces) over
  // 4 x the mixed Voronoi area): its automatic weights are c = 4 here.
  float heat = 4.0f;
  bool visibility = true;   // a bone only heats vertices that see it (the segment to it crosses no triangle)
  // Only a vertex's nearest bones heat it (when visible); a vertex whose
  // nearest bone is hidden gets no heat of its own (Blender's automatic
  // weights). false: the nearest *visible* bone heats it (Pinocchio's rule),
  // which binds a part overlapped by another to whatever bone it sees.
  bool nearest_only = true;
  // A bone's distance from a vertex is divided by (1 + cos) / 2 (+ 0.0005),
  // cos between the vertex normal and the direction from the bone to it
  // (Blender's automatic weights): the bone the surface faces away from is
  // nearer than one it faces. Needs outward normals (consistent winding).
  bool facing_distance = true;
  // Blender's limit on the solved heat (heat_limit_weight): a joint's weight
  // under cut_below is dropped and one from cut_below to ramp_until scaled
  // linearly from 0 up to ramp_until, so a far bone's faint diffusion tail is
  // no influence (artists paint none). cut_below = 0: the solved heat as is
  // (what skinweights-any models from before the limit read as their prior).
  // 0 <= cut_below <= ramp_until.
  float cut_below = 0.025f;
  float ramp_until = 0.05f;
  int max_influences = 4;   // kept per vertex (largest), renormalised
  float min_weight = 0.01f; // influences below this fraction of the vertex's total dropped
  // A child whose direction from the joint makes a cosine below this with the
  // parent's bone is a branch (shoulders off the neck, legs off a root at the
  // floor): not one of the joint's segments. -1 keeps every child.
  float branch_cos = 0.5f;
  // Where a child carries the parent's direction straight on (cosine at
  // least this: the chest going on to the neck, a forearm to the middle
  // finger), the joint is one bone ending there, as a rig's bone has one
  // tail (Blender's bones; artists weight that way): the other children are
  // branches however little they turn (the shoulders starting just above the
  // chest). Without such a child the segments fan to every child within
  // branch_cos (a head to its two ears). A root's children all start on its
  // axis, so it keeps its fan. Above 1: always the fan (skinweights-any
  // models from before this rule).
  float continue_cos = 0.98f;
  // A leaf joint's segment continues its parent's direction for this fraction
  // of the parent's length (0: the joint's point; a vertex past its parent's
  // tail then goes to it).
  float leaf_extension = 0.5f;
  // Joints that may receive weight ([num_joints], 1 = deforms); empty = the
  // rules above (every joint but the controls).
  std::vector<std::uint8_t> deforming;
  // Per joint, applied last ([num_joints] or empty): +1 always a bone, -1
  // never (a control), 0 as decided above -- the user's word where the
  // control rules get a rig wrong (gat predict-weights --bone / --control).
  std::vector<std::int8_t> joint_override;
};

// Per-vertex weights over the character's joints (each vertex: 1..max_influences
// joints, summing to 1). Throws InvalidArgument naming the character when the
// mesh or skeleton is invalid or no joint deforms.
SkinWeights bone_heat_weights(const Character& ch, const BoneHeatParams& params = {});

// A model's weights for `ch` mixed with bone heat's (--heat-blend):
// blend_weights(model, bone_heat_weights(ch, params), share,
// params.max_influences) (rig/blend_weights.hpp); `model` itself, and no bone
// heat computed, when share is 0.
SkinWeights mix_with_bone_heat(const Character& ch, const SkinWeights& model, float share,
                               const BoneHeatParams& params = {});

// The bone segments of every joint (see above), bind frame: per joint a list
// of (head, tail) pairs.
struct BoneSegment {
  Vec3 a, b;
};
// Reads params' branch_cos, continue_cos and leaf_extension.
std::vector<std::vector<BoneSegment>> bone_segments(const Skeleton& s, const BoneHeatParams& params = {});

}  // namespace gatcore::character
