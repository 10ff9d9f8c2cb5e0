#pragma once
// Skeleton-agnostic skin-weight features (in the spirit of RigNet's
// skinning network, Xu et al. 2020): instead of one column per bone of a
// training super skeleton, every vertex lists its K nearest bones of its own
// skeleton (by distance to the bones' segments, deform/bone_heat.hpp's
// bone_segments) and describes each (vertex, bone) pair by bone-relative
// quantities that mean the same on any rig. A model then scores the K
// candidates and softmaxes over them: any joint count, any names.
//
// Row of a vertex: rest position (3), rest normal (3) (normalised, like
// NeuroSkinning's), then per candidate k = 0..K-1 (nearest first)
// kPairFeatures columns:
//   distance to the bone, distance minus the nearest candidate's, position
//   along the bone (from its head), distance from the bone's line, height
//   above the bone's closest point, bone length, fraction along the bone
//   (clamped to [0, 1]), depth in the hierarchy / the skeleton's depth,
//   1 for a leaf joint, the bone's bone-heat weight at the vertex
//   (deform/bone_heat.hpp, not cut to the top few influences: a classical
//   prior the network corrects; the rules of the model's, prior_bone_heat)
// (lengths in the normalised frame: height 1). Candidates past the joint
// count are zero rows with joint -1.
#include <cstdint>
#include <vector>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::character {

inline constexpr int kVertexColumns = 6;  // rest position (3), rest normal (3): the world frame's columns
inline constexpr int kPairFeatures = 10;
inline constexpr int kDefaultCandidates = 8;
inline constexpr int kBoneHeatPairColumn = 9;  // bone heat's weight, within a candidate's columns
// Added to bone heat's weight before the log of the prior: a candidate bone
// heat gives nothing starts 6.9 logits below one it gives everything, a gap
// the network can close where the artist disagrees; small enough that the
// untrained model is bone heat to within K * eps per weight.
inline constexpr float kBoneHeatPriorEps = 1e-3f;

struct BoneCandidates {
  int k = 0;                        // candidates per vertex
  int valid = 0;                    // min(k, joints): candidates that name a joint
  std::vector<std::int32_t> joint;  // [n * k] joint of candidate (v, c), nearest first; -1 past `valid`
  Tensor features;                  // [n, 6 + k * kPairFeatures]
};

std::int64_t bone_candidate_feature_dim(int k);

// The bone heat a skinweights-any model reads (the segments its candidates
// are measured from, its bone-heat column and its logit prior): the rules its
// config records (models::ModelConfig::prior_weight_limit,
// prior_straight_chains), so a model from before a rule reads the bone heat
// it was trained on; not cut to a few influences.
BoneHeatParams prior_bone_heat(const models::ModelConfig& cfg);

// Throws InvalidArgument for k < 1 or a character without joints. `heat`:
// the model's (prior_bone_heat).
BoneCandidates bone_candidate_features(const PreparedCharacter& pc, int k, const BoneHeatParams& heat);

// The character's weights over candidates ([n, k], rows summing to 1: the
// artist's weights of the candidate joints renormalised; a vertex whose
// joints are all outside its candidates puts 1 on its nearest candidate).
Tensor candidate_targets(const BoneCandidates& c, const SkinWeights& w);

// [n, 1]: the share of each vertex's weights (of their sum) that its
// candidates hold, 0 where none does (models::Sample::target_mass): with it a
// validation L1 over the candidates is the L1 over the character's joints.
Tensor candidate_target_mass(const BoneCandidates& c, const SkinWeights& w);
// Per vertex, the candidate column of its largest artist weight (ties: the
// lower joint index, as gat eval's dominant bone), -1 where that joint is not
// a candidate (models::Sample::target_dominant).
std::vector<std::int32_t> candidate_target_dominant(const BoneCandidates& c, const SkinWeights& w);

// The log prior of skinweights-any's logits (models::Sample::prior, [n, k]):
// log(bone heat's weight of the candidate + eps) for the valid candidates, 0
// past them (masked). softmax of it is bone heat over the vertex's
// candidates, renormalised, to within k * eps.
Tensor bone_heat_log_prior(const BoneCandidates& c, float eps = kBoneHeatPriorEps);

// Candidate probabilities [n, k] -> weights over the character's joints.
SkinWeights weights_from_candidates(const BoneCandidates& c, const Tensor& probabilities);

}  // namespace gatcore::character
