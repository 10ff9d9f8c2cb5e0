#pragma once
// Influence limits on skin weights: at most `max_influences` joints per
// vertex (the largest), influences below `min_weight` of the vertex's total
// dropped, the rest renormalised to sum to 1. A vertex always keeps its
// largest influence, so no vertex is left without weights (a
// forced top-4 caps bone precision near 0.5 on characters whose artists use
// about two influences; --min-weight prunes the tiny ones).
#include <cstdint>
#include <span>

#include "gatcore/character/rig/mesh.hpp"

namespace gatcore::character {

// Throws InvalidArgument when max_influences < 1 or min_weight is not in
// [0, 1), or a vertex has no positive weight.
SkinWeights limit_weights(const SkinWeights& w, int max_influences, float min_weight = 0.0f);

// The same on dense rows ([n x cols], row-major, in place); entries outside
// `mask` (when given, [cols]) count as 0. A row with no positive entry stays 0.
void limit_weights_dense(std::span<float> dense, std::int64_t cols, int max_influences, float min_weight,
                         std::span<const std::uint8_t> mask = {});

}  // namespace gatcore::character
