#pragma once
// DenseGATs at playback: a character posed frame by frame, each frame linear
// blend skinned and corrected by a trained displacement model (densegats, its
// ablations, origat), with the features computed exactly as in training:
// by the same functions (features/frame_features.hpp), not through the
// training-sample builder.
#include <span>
#include <string>
#include <vector>

#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::character {

// A character bound to a displacement model's bones and features, ready for deform_frame.
struct CorrectiveBinding {
  PreparedCharacter prepared;  // world frame; poses are of prepared.character.skeleton
  BoneMapping mapping;         // joints -> the model's bones (empty with nearest-joint columns)
  std::int64_t num_bones = 0;
  int nearest_joints = 0;      // > 0: the model's joint columns are each vertex's K nearest joints
};
// `distortion_scales`: those the model was trained with (checkpoint_distortion_scales);
// `nearest_joints`: checkpoint_nearest_joints (0: map the joints onto `bones`
// by name; K: any skeleton, `bones` and `aliases` unused).
CorrectiveBinding make_corrective_binding(const Character& ch, const std::vector<std::string>& bones,
                                            const BoneAliases& aliases = {}, std::span<const int> distortion_scales = {},
                                            int nearest_joints = 0);

struct CorrectedFrame {
  std::vector<float> lbs;        // [3 n] LBS positions, glTF world frame (welded vertices)
  std::vector<float> corrected;  // [3 n] lbs + the predicted correction, same frame
  double ms_features = 0, ms_inference = 0;
};
// LBS of `pose`, DenseGATs features of the posed mesh (normalised, the model's
// bone order), the model's prediction on the whole mesh (on the model's
// device), converted from normalised units back to the character's.
CorrectedFrame deform_frame(const CorrectiveBinding& d, models::Model& model, const models::Normaliser& norm,
                            const Pose& pose);

}  // namespace gatcore::character
