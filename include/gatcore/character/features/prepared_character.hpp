#pragma once
// A character prepared once for its node features, by training (data/) and
// inference (inference/) alike: the character re-expressed in its world bind
// frame (so Delta Mush deltas and features are in world units), its
// normalisation, the Delta Mush binding (training: the reference deformer,
// its parameters the dataset's record; inference: zero iterations, only its
// one-ring adjacency for the distortion columns), the mesh graph, and the
// detail-distortion rest details.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/deform/reference_deformer.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/rig/character.hpp"
#include "gatcore/graph.hpp"

namespace gatcore::character {

// The character with bind_to_world applied: positions in the world frame,
// inverse bind matrices compensated, so skinning the world bind pose gives
// the world rest mesh.
Character to_world(const Character& ch, const Mat4& bind_to_world);

struct PreparedCharacter {
  Character character;  // world frame (to_world)
  NormalisationStats normalisation;  // of the world-frame character (bind_to_world = identity); not the feature statistics (models::Normaliser)
  DeltaMush delta_mush;
  CsrGraph mesh_graph;  // mesh edges + self-loops
  Pose rest;            // bind pose of the world-frame character
  // DenseGATs' detail-distortion columns (detail_distortion.hpp): the
  // smoothing scales and the world-frame rest details, one per scale.
  std::vector<int> distortion_scales;
  std::vector<std::vector<float>> rest_details;
  // Training only (data/): the targets' reference deformer when it is not
  // the Delta Mush binding above (ARAP, or file targets with the pose of each
  // of their frames); null: Delta Mush.
  std::shared_ptr<const ReferenceTargets> reference;
  std::vector<Pose> target_poses;
};
PreparedCharacter prepare_character(const Character& ch, const DeltaMushParams& params = {},
                                    std::span<const int> distortion_scales = {});
// Sets the scales (checked) and recomputes the rest details.
void set_distortion_scales(PreparedCharacter& pc, std::span<const int> scales);

// The two halves of the distortion columns over the whole mesh, root frame,
// normalised, [scales][3 n] each: the rest details carried by `skinning`
// (skinning_matrices of the pose) and the details of the root-frame LBS mesh
// `lbs_root`. The distortion is rest - posed.
struct DetailHalves {
  std::vector<std::vector<float>> rest, posed;
};
DetailHalves detail_halves(const PreparedCharacter& pc, std::span<const Mat4> skinning,
                           std::span<const float> lbs_root, const Mat4& to_root);

// The joint that carries root motion: the topmost ancestor of the
// normalisation's origin joint (the hips).
std::int32_t root_motion_joint(const PreparedCharacter& pc);

}  // namespace gatcore::character
