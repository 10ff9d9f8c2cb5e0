#pragma once
// Skeleton-agnostic joint columns for the DenseGATs family.
//
// The paper's features give a vertex its distance to every joint of the
// training skeleton, one column per bone *name*: a character with another
// skeleton (Mixamo, Unreal, a quadruped, other bone counts) fills the wrong
// columns or none. "nearest:K" instead gives each vertex its distances to
// the K joints nearest to it, nearest first: the same meaning on any
// skeleton, no names. Which joints they are is not said; the mesh context
// (graph attention) and the detail-distortion columns carry the rest.
// Training (data/training_data.cpp), `gat deform` (inference/corrective.cpp)
// and the runtime (src/runtime/deformer.cpp) share the row function, so the
// three compute the same numbers.
#include <cstdint>
#include <string>

#include "gatcore/tensor.hpp"

namespace gatcore::character {

// Most joint columns a model may ask for (the runtime keeps a row's K
// nearest in a fixed array: no allocation per frame).
inline constexpr int kMaxNearestJoints = 32;

// out[0..K): the K smallest of d[0..J), ascending. A skeleton with fewer
// than K joints repeats its farthest distance (the columns stay ordered and
// mean "no nearer joint"). J >= 1, 1 <= K <= kMaxNearestJoints.
void nearest_joint_distances(const float* d, std::int64_t J, int K, float* out);

// [m, 6 + J] (position, normal, distance to each joint of the character, as
// densegats_frame_features) -> [m, 6 + K]: position, normal, the K nearest.
Tensor nearest_joint_columns(const Tensor& joint_features, int K);

// "nearest:K" <-> K (0: the paper's bone columns, written "bones"). Throws
// naming `what` for anything else or K outside [1, kMaxNearestJoints].
int parse_joint_columns(const std::string& text, const std::string& what);
std::string format_joint_columns(int nearest);

}  // namespace gatcore::character
