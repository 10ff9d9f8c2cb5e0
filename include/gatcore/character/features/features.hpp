#pragma once
// Node features of the two papers, normalisation, and geodesic neighbourhoods.
#include <cstdint>
#include <span>
#include <vector>

#include "gatcore/character/rig/character.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::character {

// NeuroSkinning's normalisation. Bind-space data (the file's vertex
// positions, inverse(inverse_bind)) is first brought into the world frame of
// the rest pose by `bind_to_world` (the rest-pose skinning matrix of the
// origin joint: it undoes e.g. FBX2glTF's Z-up / x100 armature), which fixes
// the orientation (glTF: +Y up). World positions are then normalised as
// p' = (p - origin) * scale, origin = world rest position of a common bone
// (hips / pelvis / root, else the first root), scale = 1 / rest mesh height.
struct NormalisationStats {
  Mat4 bind_to_world = mat4_identity();
  Vec3 origin{0.0f, 0.0f, 0.0f};
  float scale = 1.0f;
  std::int32_t origin_joint = -1;
};
NormalisationStats compute_normalisation(const Character& c);
// World positions -> normalised.
Vec3 apply_normalisation(const NormalisationStats& s, const Vec3& p);
std::vector<float> apply_normalisation(const NormalisationStats& s, std::span<const float> positions);
void apply_normalisation(const NormalisationStats& s, std::span<const float> positions, std::span<float> out);
// Bind-space positions -> normalised (bind_to_world, then the above).
std::vector<float> normalise_bind_positions(const NormalisationStats& s, std::span<const float> positions);
// Bind-pose joint positions, normalised.
std::vector<Vec3> normalised_bind_joints(const NormalisationStats& s, const Skeleton& sk);

// DenseGATs: [posed position (3), posed normal (3), distance to each joint (J)].
Tensor densegats_features(std::span<const float> posed_positions, std::span<const float> posed_normals,
                          std::span<const Vec3> joint_positions);
// The same into `out` ([n, 6 + J] CPU tensor; no allocation).
void densegats_features(std::span<const float> posed_positions, std::span<const float> posed_normals,
                        std::span<const Vec3> joint_positions, const Tensor& out);
// NeuroSkinning: [rest position (3), rest normal (3), shortest distance to
// each bone segment (J)]. Bone j spans from joint j to each of its children
// (the minimum over children); a leaf joint's bone is its point.
Tensor neuroskinning_features(std::span<const float> rest_positions, std::span<const float> rest_normals,
                              std::span<const Vec3> joint_positions, std::span<const std::int32_t> parents);
// Joint positions (translations of the global transforms).
std::vector<Vec3> joint_positions(std::span<const Mat4> globals);

// For every vertex, its k nearest vertices (itself first) by geodesic distance
// along mesh edges (Dijkstra, Euclidean edge lengths; fewer than k when its
// component is smaller). Parallel over vertices with oneTBB. Returned as a
// graph whose row i lists those vertices (graph_from_neighbour_lists).
CsrGraph geodesic_knn(std::span<const float> positions, std::span<const std::int32_t> triangles, int k);
std::vector<std::vector<std::int32_t>> geodesic_knn_lists(std::span<const float> positions,
                                                          std::span<const std::int32_t> triangles, int k);

}  // namespace gatcore::character
