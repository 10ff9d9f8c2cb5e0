#pragma once
// NeuroSkinning's evaluation of predicted skin weights on one character
// (the paper's Tables 3, 4 and 8): bone-selection precision / recall, per-vertex
// L1 weight error, and the deformation error at the worst random poses
// (LBS with the predicted weights against LBS with the artist's weights),
// normalised by the character's height. Weights are dense rows over a super
// skeleton; `joint_to_bone` maps the character's joints to its bones.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/eval/boundaries.hpp"
#include "gatcore/character/eval/metrics.hpp"

namespace gatcore::character {

struct WeightEvalOptions {
  int poses = 16;            // random poses for the deformation error
  float pose_angle = 0.5f;   // uniform_limits(+-pose_angle) around the bind pose
  std::uint32_t seed = 0;    // pose generator seed (per character: seed ^ character index)
  double threshold = 1e-4;   // bone selected by the prediction when its weight > threshold
  int worst = 2;             // poses pooled for the deformation error
  // Influences of the prediction below this fraction of the vertex's total
  // are dropped (renormalised) before every metric (limit_weights_dense);
  // 0 keeps them all. Artists often use about 2 influences per vertex, so a
  // forced top-4 caps precision near 0.5.
  float min_weight = 0.0f;
};

// Vertices whose predicted dominant bone is `predicted` where the artist's
// is `truth` (joint names of the character).
struct BoneConfusion {
  std::string truth, predicted;
  std::int64_t vertices = 0;
};

struct CharacterWeightEval {
  std::string name;
  std::int64_t vertices = 0;
  double height = 0;            // world rest height (deformation errors are divided by it)
  WeightMetrics weights;        // precision / recall / L1 over the character's own bones
  DistanceStats deformation;    // worst poses, mean / max / min divided by height
  std::vector<float> vertex_l1; // per-vertex L1 weight error (for error maps)
  double dominant = 0;          // fraction of vertices whose largest predicted bone is the artist's largest
  // Where the dominant bone is wrong: every (artist's, predicted) pair of
  // joints, most vertices first. Shows which boundaries a method places
  // differently from the artist (e.g. a neck given to the head).
  std::vector<BoneConfusion> confusions;
  // The same per boundary artists place by eye (head/neck, ..., ankle), the
  // joints' body regions from their names (eval/boundaries.hpp).
  std::vector<BoundaryConfusion> boundaries;
};

// Dense [n x num_bones] super-skeleton weights -> the character's joints
// (bones the character lacks are dropped, each vertex renormalised; a vertex
// with no positive weight left keeps none). Throws if joint_to_bone maps
// two joints to one bone or a bone index is out of range.
SkinWeights weights_from_super(std::span<const float> dense, std::int64_t num_bones,
                               const std::vector<std::int32_t>& joint_to_bone);

// Deformation error of `predicted` against `truth` weights (both over the
// character's joints) in the given poses: per-vertex distance between the
// two LBS meshes per pose, the `worst` poses pooled, divided by the
// character's height (worst_poses_error).
DistanceStats deformation_error(const PreparedCharacter& pc, const SkinWeights& predicted, const SkinWeights& truth,
                                std::span<const Pose> poses, int worst = 2);

// Evaluates `predicted` against `truth` (both dense [n x num_bones]) on the
// prepared (world-frame) character. `mask` ([num_bones], optional) restricts
// precision / recall / L1 to the character's bones. Pose p of the deformation
// error is the p-th random_pose of a std::mt19937 seeded with
// opts.seed ^ (0x9e3779b9 * (character_index + 1)).
CharacterWeightEval evaluate_character_weights(const PreparedCharacter& pc, std::span<const float> predicted,
                                               std::span<const float> truth, std::int64_t num_bones,
                                               const std::vector<std::int32_t>& joint_to_bone,
                                               std::span<const std::uint8_t> mask, const WeightEvalOptions& opts,
                                               std::int32_t character_index = 0);

// Overall figures over characters: the mean of the per-character precision,
// recall, L1 mean, deformation mean and dominant-bone accuracy; the maximum
// of the maxima.
struct WeightEvalSummary {
  int characters = 0;
  double precision = 0, recall = 0, l1_mean = 0, l1_max = 0, deform_mean = 0, deform_max = 0, dominant = 0;
};

// Fraction of the n rows whose largest entry (over `mask`) is at the same
// column in `predicted` and `truth` (ties: the first column).
double dominant_accuracy(std::span<const float> predicted, std::span<const float> truth, std::int64_t cols,
                         std::span<const std::uint8_t> mask = {});
WeightEvalSummary summarise_weight_eval(const std::vector<CharacterWeightEval>& per_character);

// The confusions of dominant_accuracy's rows: (truth column, predicted
// column) -> rows, for the rows where they differ; most rows first, ties by
// column. Columns name nothing: evaluate_character_weights names them.
std::vector<std::array<std::int64_t, 3>> dominant_confusions(std::span<const float> predicted,
                                                             std::span<const float> truth, std::int64_t cols,
                                                             std::span<const std::uint8_t> mask = {});

// A Markdown table: one row per character and an "overall" row.
std::string weight_eval_markdown(const std::vector<CharacterWeightEval>& per_character);
// Markdown: per character, its `top` largest confusions ("artist's joint ->
// predicted joint: vertices") and its boundaries' (crossed / vertices), then
// a table per boundary over all characters; empty if top < 1.
std::string weight_eval_confusions_markdown(const std::vector<CharacterWeightEval>& per_character, int top);
// JSON text: {"method", "options", "characters": [...], "overall": {...}};
// each character lists its `confusions` largest confusions and its
// boundaries, "overall" the boundaries summed (0: none of them).
std::string weight_eval_json(const std::string& method, const std::vector<CharacterWeightEval>& per_character,
                             const WeightEvalOptions& opts, int confusions = 0);

// Writes `text` to "<path>.tmp" and renames it over `path`; throws
// InvalidArgument naming the path on failure.
void write_text_atomic(const std::string& path, const std::string& text);

}  // namespace gatcore::character
