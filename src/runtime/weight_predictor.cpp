// runtime::WeightPredictor: a skin-weight checkpoint applied to a new
// character (predict_skin_weights / predict_skin_weights_any, then
// --heat-blend's mix, as gat predict-weights), behind the runtime's load /
// predict interface.
#include <cmath>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/runtime.hpp"

namespace gatcore::runtime {

struct LoadedWeights {
  models::LoadedModel lm;
  std::vector<std::string> bones;  // empty for skinweights-any
  bool any = false;                // skinweights-any: each vertex's own nearest bones
  float heat_blend = 0.0f;
};

WeightPredictor::WeightPredictor(std::unique_ptr<LoadedWeights> m) : model_(std::move(m)) {}
WeightPredictor::WeightPredictor(WeightPredictor&&) noexcept = default;
WeightPredictor& WeightPredictor::operator=(WeightPredictor&&) noexcept = default;
WeightPredictor::~WeightPredictor() = default;

WeightPredictor WeightPredictor::load(const std::string& path, DeviceChoice device) {
  const Device dev = resolve_device(device);
  auto m = std::make_unique<LoadedWeights>();
  m->lm = models::load_checkpoint(path);
  m->any = models::any_skeleton(m->lm.model->config().kind());
  if (!m->any) m->bones = character::character_model_bones(m->lm, path, models::Task::weights);
  m->lm.model->to(dev);
  m->lm.model->fold_batch_norm();
  return WeightPredictor(std::move(m));
}

const std::vector<std::string>& WeightPredictor::bones() const { return model_->bones; }

void WeightPredictor::set_heat_blend(float share) {
  GATCORE_CHECK(model_, "WeightPredictor::set_heat_blend: no model loaded");
  GATCORE_CHECK(std::isfinite(share) && share >= 0.0f && share <= 1.0f,
                "WeightPredictor::set_heat_blend: share must be in [0, 1], got ", share);
  model_->heat_blend = share;
}

character::SkinWeights WeightPredictor::predict(const character::Mesh& rest, const character::Skeleton& skeleton,
                                                int max_influences, const BindOptions& opt) {
  GATCORE_CHECK(model_, "WeightPredictor::predict: no model loaded");
  skeleton.validate((opt.name + " skeleton").c_str());
  character::Character ch;
  ch.name = opt.name;
  ch.skeleton = skeleton;
  if (ch.skeleton.root_parent.size() != ch.skeleton.names.size())
    ch.skeleton.root_parent.assign(ch.skeleton.names.size(), character::mat4_identity());
  ch.mesh.positions = rest.positions;
  ch.mesh.triangles = rest.triangles;
  // The mesh's own weights are not used; a placeholder binding to joint 0 lets
  // Mesh::validate check positions and triangles.
  const std::int64_t n = ch.mesh.num_vertices();
  ch.mesh.weights.ptr.resize(std::size_t(n + 1));
  for (std::int64_t v = 0; v <= n; ++v) ch.mesh.weights.ptr[std::size_t(v)] = v;
  ch.mesh.weights.joint.assign(std::size_t(n), 0);
  ch.mesh.weights.weight.assign(std::size_t(n), 1.0f);
  ch.mesh.validate(skeleton.num_joints(), (opt.name + " mesh").c_str());
  GATCORE_CHECK(n > 0 && ch.mesh.num_triangles() > 0, opt.name, ": the mesh has no triangles");
  GATCORE_CHECK(!model_->any || opt.aliases.pairs.empty(), opt.name,
                ": aliases have no effect with skinweights-any (it matches no bone names)");
  const character::SkinWeights w =
      model_->any ? character::predict_skin_weights_any(*model_->lm.model, model_->lm.norm, ch, max_influences).weights
                  : character::predict_skin_weights(*model_->lm.model, model_->lm.norm, model_->bones, ch,
                                                    max_influences, opt.aliases)
                        .weights;
  character::BoneHeatParams bp;  // gat predict-weights --heat-blend's: min weight 0.01
  bp.max_influences = max_influences;
  return character::mix_with_bone_heat(ch, w, model_->heat_blend, bp);
}

}  // namespace gatcore::runtime
