#pragma once
// The node features of a prepared character, computed the same way for a
// training sample (data/dataset.hpp: make_densegats_sample,
// make_neuroskinning_sample) and at inference (inference/corrective.hpp:
// deform_frame; inference/weight_prediction.hpp): the two share these
// functions, not the sample structs.
//
// DenseGATs features are expressed in the character's root frame: the
// skeleton root above the hips (the joint that carries root motion) is moved
// back to its rest placement, so a character walking away or turning gives
// the network the same inputs as one posed in place (random training poses
// keep the root at rest). `root_motion` maps that frame back to the world.
#include <cstdint>
#include <span>
#include <vector>

#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::character {

// One pose of a prepared character, whole mesh.
struct PosedFrame {
  std::vector<Mat4> skinning;            // skinning matrices of the pose
  std::vector<float> lbs_world;          // [3 n] LBS positions, world frame
  std::vector<float> lbs;                // [3 n] the same, normalised
  Mat4 root_motion = mat4_identity();    // the root's current world transform times its rest inverse (rigid)
  Mat4 to_root = mat4_identity();        // inverse(root_motion)
  std::vector<float> lbs_root;           // [3 n] LBS positions, root frame, normalised
  std::vector<float> normals;            // [3 n] vertex normals of lbs_root
  std::vector<Vec3> joints;              // joint positions, root frame, normalised
};
PosedFrame pose_frame(const PreparedCharacter& pc, const Pose& pose);
// The same into `f` from the joints' global transforms (global_transforms
// of the pose): f's vectors are resized, so once they have the character's
// sizes nothing is allocated (the runtime's per-frame path, runtime.hpp).
// `inv_rest_root` = rest_root_inverse(pc); `normals_scratch`: [3 n].
void pose_frame(const PreparedCharacter& pc, std::span<const Mat4> globals, const Mat4& inv_rest_root, PosedFrame& f,
                std::span<double> normals_scratch);
// Inverse of the root-motion joint's global transform in the rest pose.
Mat4 rest_root_inverse(const PreparedCharacter& pc);
// A world-frame position (lbs_world, or a deformer's output) in the root frame, normalised.
std::vector<float> to_root_frame(const PreparedCharacter& pc, const PosedFrame& f, std::span<const float> world);

// DenseGATs' paper features of `vertices` (indices into the mesh):
// [m, 6 + J] posed position, posed normal, distance to each joint.
Tensor densegats_frame_features(const PosedFrame& f, std::span<const std::int32_t> vertices);
// The detail-distortion columns of `vertices` at the character's S scales:
// [m, 3 S] (normalised, root frame); undefined when S = 0.
Tensor distortion_frame_features(const PreparedCharacter& pc, const PosedFrame& f,
                                 std::span<const std::int32_t> vertices);
// The model's input: `bone_features` ([m, 6 + B], the features in the
// model's bone columns) followed by the distortion columns (undefined or
// 0 columns: none).
Tensor densegats_model_features(const Tensor& bone_features, const Tensor& distortion);
// A root-frame displacement (target or prediction) in the world frame (normalised units).
Vec3 root_offset_to_world(const Mat4& root_motion, const Vec3& offset);

// NeuroSkinning's features of `vertices` of the rest mesh: [m, 6 + J] rest
// position, rest normal, distance to each bone segment (normalised).
Tensor neuroskinning_rest_features(const PreparedCharacter& pc, std::span<const std::int32_t> vertices);

// 0 .. n-1.
std::vector<std::int32_t> all_vertices(std::int64_t n);

}  // namespace gatcore::character
