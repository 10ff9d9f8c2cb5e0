// gat predict-weights' and gat deform's outputs computed the way the tool
// computed them before it went through the runtime: the character layer's
// functions on the imported character (predict_skin_weights /
// predict_skin_weights_any, mix_with_bone_heat, limit_weights,
// bone_heat_weights; make_corrective_binding + deform_frame on the loaded
// model), written by the same writers. tool_runtime_path.sh compares them
// byte for byte with the tool's files: the runtime path gives the old numbers.
//
//   tool_path_reference weights MODEL|heat CHARACTER.glb OUT.glb K HEAT_BLEND MIN_WEIGHT CONTROL|-
//   tool_path_reference deform MODEL CHARACTER.glb MOTION FIRST LAST OUT.glb OUT.pc2
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/corrective.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

int weights(const std::string& model, const std::string& in, const std::string& out, int k, float blend,
            float min_weight, const std::string& control) {
  const Character ch = load_gltf(in);
  BoneHeatParams bp;
  bp.max_influences = k;
  if (control != "-") {
    bp.joint_override.assign(std::size_t(ch.skeleton.num_joints()), 0);
    const std::int32_t j = ch.skeleton.find(control);
    if (j < 0) throw std::runtime_error(in + ": no joint " + control);
    bp.joint_override[std::size_t(j)] = -1;
  }
  SkinWeights w;
  if (model == "heat") {
    if (min_weight >= 0) bp.min_weight = min_weight;
    w = bone_heat_weights(ch, bp);
  } else {
    models::LoadedModel lm = models::load_checkpoint(model);
    lm.model->fold_batch_norm();
    w = models::any_skeleton(lm.model->config().kind())
            ? predict_skin_weights_any(*lm.model, lm.norm, ch, k).weights
            : predict_skin_weights(*lm.model, lm.norm, character_model_bones(lm, model, models::Task::weights), ch, k)
                  .weights;
    if (blend > 0) w = mix_with_bone_heat(ch, w, blend, bp);
    if (min_weight > 0) w = limit_weights(w, k, min_weight);
  }
  save_gltf_with_weights(in, ch, w, out, k);
  return 0;
}

int deform(const std::string& model, const std::string& in, const std::string& motion_path, long first, long last,
           const std::string& out, const std::string& pc2) {
  models::LoadedModel lm = models::load_checkpoint(model);
  const std::vector<std::string> bones = character_model_bones(lm, model, models::Task::displacement);
  const Character ch = load_character(in);
  const Motion motion = load_motion(motion_path);
  const CorrectiveBinding d = make_corrective_binding(ch, bones, {}, checkpoint_distortion_scales(lm.file, model),
                                                      checkpoint_nearest_joints(lm.file, model));
  RetargetOptions ro;
  ro.target_name = in;
  const Clip clip = retarget(motion, d.prepared.character.skeleton, mat4_identity(), ro);
  lm.model->fold_batch_norm();
  BakedFrames baked;
  baked.fps = clip.fps;
  for (long f = first; f < last; ++f)
    baked.positions.push_back(deform_frame(d, *lm.model, lm.norm, clip.frames[std::size_t(f)]).corrected);
  write_object_point_caches(pc2, object_point_caches(ch, baked, UpAxis::y, 1.0f));
  save_gltf_morph_animation(in, ch, baked, out);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string what = argc > 1 ? argv[1] : "";
    if (what == "weights" && argc == 9)
      return weights(argv[2], argv[3], argv[4], std::atoi(argv[5]), std::strtof(argv[6], nullptr),
                     std::strtof(argv[7], nullptr), argv[8]);
    if (what == "deform" && argc == 9)
      return deform(argv[2], argv[3], argv[4], std::atol(argv[5]), std::atol(argv[6]), argv[7], argv[8]);
    std::fprintf(stderr, "usage: tool_path_reference weights MODEL|heat IN OUT K HEAT_BLEND MIN_WEIGHT CONTROL|-\n"
                         "       tool_path_reference deform MODEL IN MOTION FIRST LAST OUT.glb OUT.pc2\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tool_path_reference: %s\n", e.what());
    return 1;
  }
}
