#pragma once
// Per-joint anatomical rotation limits for random training poses: a table of
// rules (a glob pattern on the normalised joint name, as the super skeleton
// normalises it: "UpperArm.L" -> "upperarm.l"; per axis min / max in
// degrees), matched in order (first match wins), with a fallback for joints
// no rule names. Roots stay at rest.
//
// File format (JSON):
//   {"format": "gatcore-joint-limits", "version": 1,
//    "default": {"x": [-10, 10], "y": [-10, 10], "z": [-10, 10]},
//    "joints": [{"match": "lowerleg.*", "x": [0, 120], "y": [-3, 3], "z": [-3, 3]}, ...]}
// Axes are the joint's local X, Y, Z (Euler XYZ after the rest rotation, as
// random_pose applies them); an absent axis is fixed at 0.
//
// A rule may also give "flex": [lo, hi], degrees of flexion (positive: the
// joint's first child moves towards the character's front, where the foot*
// joints' bones point in the bind pose: to the toes, or along the rig's bone
// axis for feet without toes, rig/bone_axis.hpp). Rigs disagree on the axis and
// the sign of, say, hip flexion (the Quaternius men flex the hips about Z,
// mirrored left / right, the women about X), so one x/y/z range cannot give
// a deep flexion without an equally deep hyperextension somewhere. limits_for
// finds, per joint, which of local X and Z moves the child most along the
// front and in which sign, and gives that axis [lo, hi] in flexion terms; the
// other axes keep the rule's x/y/z ranges. Where there is no front (no joint
// named foot*) or the child moves sideways about both axes, the rule's x/y/z
// ranges apply unchanged.
#include <string>
#include <vector>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/skeleton.hpp"

namespace gatcore::character {

struct FlexionRange {
  bool enabled = false;
  float lo = 0.0f, hi = 0.0f;  // degrees; positive flexes (the child moves to the front)
};

struct JointLimitRule {
  std::string pattern;  // glob on normalised names: '*' any run, '?' one character
  JointLimit degrees;   // lo / hi per axis, in degrees
  FlexionRange flex;    // the file's "flex" (see above)
};

// Which local axis (0 = X, 2 = Z) of joint `j` in the bind pose flexes it,
// and its sign (+1: a positive angle moves the first child to the front);
// axis -1 when the skeleton has no foot* joint, `j` no child, or neither axis
// moves the child along the front by at least half its bone length per
// radian. `front` (if given) receives the unit front direction used.
struct FlexionAxis {
  int axis = -1;
  int sign = 0;
};
FlexionAxis flexion_axis(const Skeleton& s, std::int32_t j, Vec3* front = nullptr);

struct JointLimitTable {
  std::string name = "custom";  // "humanoid" for the built-in table, else the file it came from
  JointLimit fallback_degrees;  // joints no rule matches
  std::vector<JointLimitRule> rules;

  // Quaternius / Blender-style humanoids (bones along local +Y: Y = twist;
  // hinge joints bend about local X): spine, neck, head, shoulders, arms,
  // elbows and knees as hinges, wrists, fingers, legs, feet, toes; +-10 deg
  // on every axis for anything else.
  static JointLimitTable default_humanoid();
  // Radians per joint of `s` (roots at rest); the rule (or the fallback)
  // used for each joint is reported in `matched` if given.
  std::vector<JointLimit> limits_for(const Skeleton& s, std::vector<std::string>* matched = nullptr) const;
};

// How far a pose lies outside per-joint limits (radians, as limits_for gives
// them): each joint's rotation relative to `rest` decomposed as Euler XYZ
// (rest * Rx Ry Rz, random_pose's convention), the largest amount by which
// an angle leaves [lo, hi]; 0 inside the limits. Roots, and
// `orientation_joint` with its ancestors (the hips of a retargeted motion:
// they carry the character's turning and leaning, which the root frame of
// the features removes), are not checked. The evaluation's rule for poses
// the training never covered (gat eval --max-limit-excess).
struct LimitExcess {
  float radians = 0.0f;
  std::int32_t joint = -1;  // the joint with the largest excess (-1: none)
  int axis = -1;
};
LimitExcess pose_limit_excess(const Skeleton& s, const Pose& rest, const Pose& pose,
                              const std::vector<JointLimit>& limits, std::int32_t orientation_joint = -1);

// Glob match ('*', '?') of a whole string.
bool glob_match(const std::string& pattern, const std::string& text);

// Parses a table from JSON text; `source` names it in errors (the file),
// which also name the field and the bad value.
JointLimitTable parse_joint_limits(const std::string& json_text, const std::string& source);
// Reads a file; "humanoid" gives the built-in default table.
JointLimitTable load_joint_limits(const std::string& path_or_builtin);
// The table as JSON text (the format above; parse_joint_limits reads it back).
std::string joint_limits_json(const JointLimitTable& t);

}  // namespace gatcore::character
