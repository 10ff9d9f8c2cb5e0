#pragma once
// The evaluation metrics of both papers.
#include <cstdint>
#include <span>
#include <vector>

namespace gatcore::character {

struct DistanceStats {
  double mean = 0.0, max = 0.0, min = 0.0;
  std::int64_t count = 0;  // vertex-frames
};

// DenseGATs: per-vertex Euclidean distance between predicted and reference
// positions ([3 * n] per frame), mean / max / min over all vertices of all
// frames, multiplied by `scale` (e.g. character units -> cm).
DistanceStats vertex_distance_error(const std::vector<std::vector<float>>& predicted,
                                    const std::vector<std::vector<float>>& reference, double scale = 1.0);

struct WeightMetrics {
  double precision = 0.0, recall = 0.0;  // bone selection over (vertex, bone) pairs
  double l1_mean = 0.0, l1_max = 0.0;    // per-vertex sum_b |predicted - truth|
};

// NeuroSkinning: dense [n x bones] weights; a bone is selected by the
// prediction when its weight > threshold, by the ground truth when > 0.
// `mask` (optional, [bones]) restricts everything to the character's bones.
WeightMetrics weight_metrics(std::span<const float> predicted, std::span<const float> truth, std::int64_t bones,
                             double threshold = 1e-4, std::span<const std::uint8_t> mask = {});

// NeuroSkinning: deformation error at the two worst poses. distances[p] holds
// the per-vertex distances of pose p; the two poses with the largest mean are
// pooled, mean and max are divided by `height`.
DistanceStats worst_poses_error(const std::vector<std::vector<float>>& distances, double height, int worst = 2);

}  // namespace gatcore::character
