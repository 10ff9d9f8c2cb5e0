#pragma once
// A trained checkpoint applied to a character it has never seen: which kind
// of node features it was trained on, its output / feature bones (the
// training dataset's super skeleton, by normalised name), and the mapping of
// a character's joints onto those bones.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/rig/skeleton.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::character {

// Checks that the checkpoint `path` holds a model of `task` trained on
// character features (not the embedded tube) and returns its bones (metadata
// "skeleton"), consistent with the model's input width (6 + |B|, or 6 + K
// for nearest-joint columns, plus 3 per distortion scale for displacements) and, for
// skin weights, its output width (|B|). Throws InvalidArgument naming the
// file and what does not fit (e.g. a DenseGATs checkpoint given for weights).
std::vector<std::string> character_model_bones(const models::LoadedModel& m, const std::string& path,
                                               models::Task task);

// Joints of a character -> the model's bones, by normalise_bone_name, then
// `aliases` (normalised name -> normalised bone name).
struct BoneMapping {
  std::vector<std::int32_t> joint_to_bone;  // [joints] bone index, -1: no such bone
  std::vector<std::int32_t> bone_to_joint;  // [bones] joint index, -1: the character lacks it
  std::vector<std::string> unmapped;        // joint names without a bone
  std::int32_t num_mapped() const;
};
// Throws InvalidArgument naming `what` if no joint maps (listing a few joint
// and bone names), or if two joints map to the same bone.
BoneMapping map_bones(const Skeleton& s, const std::vector<std::string>& bones, const BoneAliases& aliases,
                      const std::string& what);

// [n, 6 + J] features in the character's joint order -> [n, 6 + B] in the
// model's bone order (bones the character lacks: 0), as in training.
Tensor features_in_bone_order(const Tensor& f, const BoneMapping& m);

// The model's bones this character lacks although every training character
// had them: their columns read 0 ("absent"), an input the model never saw in
// training. In docs/RESULTS.md four finger bones per hand named differently
// made a bone-column DenseGATs 2.2 times worse than LBS over the whole body.
// Empty when the presence is not recorded.
std::vector<std::string> unseen_absent_bones(const BoneMapping& m, const std::vector<std::string>& bones,
                                             const BonePresence& presence);
// A warning for `what` naming up to 8 of those bones (the caller adds the
// remedies its command offers), or "" when `absent` is empty.
std::string unseen_absent_bones_warning(const std::string& what, const std::vector<std::string>& absent,
                                        const BonePresence& presence);

}  // namespace gatcore::character
