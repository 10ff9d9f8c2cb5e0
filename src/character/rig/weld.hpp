#pragma once
// Internal: welds file vertices by position into ch.mesh (positions of the
// first file vertex, weights averaged over the merged vertices and
// renormalised, triangles collapsed by the weld dropped) and fills
// ch.welded_from_file. infl[v]: (joint, weight > 0) of file vertex v, with a
// positive sum. tolerance: fraction of the bounding-box diagonal.
#include <cstdint>
#include <utility>
#include <vector>

#include "gatcore/character/rig/character.hpp"

namespace gatcore::character {

void weld_into(Character& ch, const std::vector<float>& pos, const std::vector<std::vector<std::pair<int, float>>>& infl,
               const std::vector<std::int32_t>& tris, float tolerance);

}  // namespace gatcore::character
