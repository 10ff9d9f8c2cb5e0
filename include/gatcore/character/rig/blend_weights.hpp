#pragma once
// Two sets of skin weights for one mesh mixed per vertex: (1 - share) * a +
// share * b over the character's joints, then the largest max_influences
// kept and renormalised (limit_weights.hpp). gat predict-weights and gat eval
// --heat-blend mix a model's prediction with bone heat's: on a character
// unlike every training family (a creature, a mech), a model's learnt
// corrections are least trustworthy, and the geometry-only method is a hedge
// (docs/RESULTS.md measures what it costs on
// characters like the training ones).
#include "gatcore/character/rig/mesh.hpp"

namespace gatcore::character {

// Throws InvalidArgument when the two have different vertex counts, share is
// not in [0, 1], max_influences < 1, or a vertex ends with no positive weight.
SkinWeights blend_weights(const SkinWeights& a, const SkinWeights& b, float share, int max_influences);

}  // namespace gatcore::character
