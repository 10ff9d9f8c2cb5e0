#pragma once
// An embedded procedural character generator, so datasets, the README's main
// job and the tests run without downloaded data: a humanoid or a quadruped
// creature skeleton with per-seed proportions, a body made of capped tubes
// swept along the joint chains (torso, limbs, tail: disjoint, overlapping
// parts, like modular game characters), garment shells (sleeves, a skirt or
// loose trousers) as further disjoint components, and smooth weights that
// blend between consecutive bones around each joint.
#include <string>
#include <cstdint>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

enum class ProceduralKind : std::uint8_t { humanoid = 0, creature = 1 };

struct ProceduralOptions {
  ProceduralKind kind = ProceduralKind::humanoid;
  std::uint32_t seed = 0;
  int ring_segments = 12;    // vertices around each tube
  int rings_per_bone = 6;    // rings along each bone
  bool garments = true;      // humanoids only
  float blend = 0.25f;       // fraction of a bone blended into the next around a joint
};

// Deterministic per options (same seed -> bit-identical character on any
// platform: uniform draws come from std::mt19937's integers). Y up, facing +Z,
// the bind pose is the rest pose, the lowest point is at y = 0.
Character procedural_character(const ProceduralOptions& opt = {});

// A small walk-in-place-and-forward motion as BVH text, on CMU joint names
// (so the default CMU -> humanoid retarget map applies): `frames` frames at
// 30 fps of one sinusoidal cycle per 24 frames — legs swinging with the
// knees bending on the back swing, arms lowered and swinging, spine and neck
// counter-rotating, hips bobbing and moving forward. Used by the README's
// examples and the tests, so neither needs downloaded motion data.
std::string procedural_swing_bvh(int frames = 24);

}  // namespace gatcore::character
