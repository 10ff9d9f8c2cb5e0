#pragma once
// The procedural two-bone tube: `rings` x `segments` vertices along +Y,
// bound to the joints "root" (y = 0) and "bone1" (y = length / 2), the
// weight of bone1 rising from 0 to 1 around the middle. One generator for
// every tube: the embedded data of gat train / eval / demo (tube_data.hpp:
// an arm with an elliptic section and smooth weights) and the tests'
// characters (capped, with a UV seam, rigid).
#include <cstdint>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

// How bone1's weight rises over the blended part of the tube, `blend` of its
// length centred on the middle.
enum class TubeFalloff : std::uint8_t {
  linear,      // straight from 0 to 1; blend 0: a step at the middle
  smoothstep,  // t^2 (3 - 2t): no kink where the blend starts and ends
};

// How each quad of the grid is split into triangles.
enum class TubeWinding : std::uint8_t {
  outward,  // along the diagonal (r, s+1)-(r+1, s); faces point out of the tube
  inward,   // along the diagonal (r, s)-(r+1, s+1); faces point into the tube
            // (the embedded tube data's: its models learnt those normals)
};

struct TubeOptions {
  int rings = 24, segments = 24;  // rings along the length, vertices around each
  float length = 2.0f, radius = 0.25f;
  float depth = 1.0f;  // the section's z radius over `radius` (< 1: an ellipse, so a twist shows)
  float blend = 0.3f;  // fraction of the length over which the weights blend, in [0, 1]
  TubeFalloff falloff = TubeFalloff::linear;
  TubeWinding winding = TubeWinding::outward;
  bool caps = false;  // a centre vertex and a fan closing each end, all weight on that end's joint
  bool seam = false;  // the first column of each ring repeated as its last (a UV seam)
};

struct TubeMesh {
  std::vector<float> positions;         // xyz per vertex: rings x columns, then the caps' centres
  std::vector<std::int32_t> triangles;  // 3 per triangle
  std::vector<float> bone1_weight;      // per vertex; root gets 1 minus it
  std::int64_t num_vertices() const { return static_cast<std::int64_t>(bone1_weight.size()); }
};

// Deterministic per options (float arithmetic in a fixed order). Throws
// InvalidArgument naming the option for rings < 2, segments < 3, a length,
// radius or depth that is not positive, or a blend outside [0, 1]
// (smoothstep: (0, 1]).
TubeMesh tube_mesh(const TubeOptions& o = {});

// The tube as a character named "tube": skeleton root -> bone1, bind pose =
// rest pose, each vertex weighted to the joints it has weight on.
Character tube_character(const TubeOptions& o = {});

}  // namespace gatcore::character
