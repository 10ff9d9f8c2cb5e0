#pragma once
// Skinning distortion of a mesh's detail coordinates: how far linear blend
// skinning moved each vertex's local shape away from its rest shape. The
// detail of x at scale k is x - S^k(x), S one step of uniform Laplacian
// smoothing over the one-ring (x <- x + 0.5 (mean of neighbours - x)). For a
// vertex with blended skinning matrix A_i,
//   distortion_i(k) = A_i (rest - S^k(rest))_i - (lbs - S^k(lbs))_i,
// which is 0 wherever skinning moves the neighbourhood rigidly and grows where
// LBS collapses or twists the surface (elbows, hips, candy wrappers): the
// artefacts a corrective deformer removes. DenseGATs' paper features (posed
// position, normal, joint distances) do not contain the rest shape, so on
// unseen characters a network cannot tell LBS artefacts from the garment's
// own folds; these columns give it that information (docs/RESULTS.md).
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gatcore/character/deform/deform.hpp"

namespace gatcore::character {

// Scales (smoothing steps) must be in [1, 1000] and strictly increasing;
// throws InvalidArgument naming `what` and the value.
void check_distortion_scales(std::span<const int> scales, std::string_view what);
// "1,4,16" <-> {1, 4, 16}; "" and "none" are the empty list.
std::vector<int> parse_distortion_scales(const std::string& text, const std::string& what);
std::string format_distortion_scales(std::span<const int> scales);

// x - S^k(x) for each k in `scales` (checked), over dm's one-ring: [scales][3 n].
std::vector<std::vector<float>> laplacian_details(const DeltaMush& dm, std::span<const float> x,
                                                  std::span<const int> scales);
// The same into `out` (one [3 n] span per scale) with two [3 n] scratch
// buffers (no allocation: the runtime's per-frame path).
void laplacian_details(const DeltaMush& dm, std::span<const float> x, std::span<const int> scales,
                       std::span<const std::span<float>> out, std::span<float> smoothed, std::span<float> scratch);

}  // namespace gatcore::character
