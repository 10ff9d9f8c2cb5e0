// runtime::WeightPredictor: a skin-weight checkpoint applied to a new
// character (predict_skin_weights / predict_skin_weights_any, then the heat
// blend's mix, then the min weight), and bone heat without a model, behind
// the runtime's load / predict interface (gat predict-weights is these calls).
#include <chrono>
#include <cmath>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/runtime.hpp"

namespace gatcore::runtime {

struct LoadedWeights {
  models::LoadedModel lm;
  std::vector<std::string> bones;  // empty for skinweights-any
  character::BonePresence presence;  // name-matched models: how many training characters had each bone
  bool any = false;                  // skinweights-any: each vertex's own nearest bones
  Device device = Device::cpu;
  float heat_blend = 0.0f, min_weight = 0.0f;
};

namespace {

// The rest mesh and skeleton as the character functions take them. The
// mesh's own weights are not used; a placeholder binding to joint 0 lets
// Mesh::validate check positions and triangles.
character::Character weight_character(const character::Mesh& rest, const character::Skeleton& skeleton,
                                      const std::string& name) {
  skeleton.validate((name + " skeleton").c_str());
  character::Character ch;
  ch.name = name;
  ch.skeleton = skeleton;
  if (ch.skeleton.root_parent.size() != ch.skeleton.names.size())
    ch.skeleton.root_parent.assign(ch.skeleton.names.size(), character::mat4_identity());
  ch.mesh.positions = rest.positions;
  ch.mesh.triangles = rest.triangles;
  const std::int64_t n = ch.mesh.num_vertices();
  ch.mesh.weights.ptr.resize(std::size_t(n + 1));
  for (std::int64_t v = 0; v <= n; ++v) ch.mesh.weights.ptr[std::size_t(v)] = v;
  ch.mesh.weights.joint.assign(std::size_t(n), 0);
  ch.mesh.weights.weight.assign(std::size_t(n), 1.0f);
  ch.mesh.validate(skeleton.num_joints(), (name + " mesh").c_str());
  GATCORE_CHECK(n > 0 && ch.mesh.num_triangles() > 0, name, ": the mesh has no triangles");
  return ch;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

WeightPredictor::WeightPredictor(std::unique_ptr<LoadedWeights> m) : model_(std::move(m)) {}
WeightPredictor::WeightPredictor(WeightPredictor&&) noexcept = default;
WeightPredictor& WeightPredictor::operator=(WeightPredictor&&) noexcept = default;
WeightPredictor::~WeightPredictor() = default;

WeightPredictor WeightPredictor::load(const std::string& path, DeviceChoice device) {
  return load(path, resolve_device(device));
}

WeightPredictor WeightPredictor::load(const std::string& path, Device device) {
  auto m = std::make_unique<LoadedWeights>();
  m->lm = models::load_checkpoint(path);
  m->any = models::any_skeleton(m->lm.model->config().kind());
  if (!m->any) {
    m->bones = character::character_model_bones(m->lm, path, models::Task::weights);
    m->presence = character::checkpoint_bone_presence(m->lm.file, path, m->bones.size());
  }
  // The post-processing calibrated for the model (gat calibrate) is its default.
  if (const auto pp = character::read_model_description(m->lm.file, path).postprocess)
    m->heat_blend = pp->heat_blend, m->min_weight = pp->min_weight;
  m->lm.model->to(device);
  m->lm.model->fold_batch_norm();
  m->device = device;
  return WeightPredictor(std::move(m));
}

const std::vector<std::string>& WeightPredictor::bones() const { return model_->bones; }
bool WeightPredictor::any_skeleton() const { return model_->any; }
std::int64_t WeightPredictor::candidates_per_vertex() const {
  return model_->any ? model_->lm.model->config().out_dim : 0;
}
const std::string& WeightPredictor::model_name() const { return model_->lm.model->config().name; }
Device WeightPredictor::device() const { return model_->device; }
float WeightPredictor::heat_blend() const { return model_->heat_blend; }
float WeightPredictor::min_weight() const { return model_->min_weight; }

void WeightPredictor::set_heat_blend(float share) {
  GATCORE_CHECK(model_, "WeightPredictor::set_heat_blend: no model loaded");
  GATCORE_CHECK(std::isfinite(share) && share >= 0.0f && share <= 1.0f,
                "WeightPredictor::set_heat_blend: share must be in [0, 1], got ", share);
  model_->heat_blend = share;
}

void WeightPredictor::set_min_weight(float share) {
  GATCORE_CHECK(model_, "WeightPredictor::set_min_weight: no model loaded");
  GATCORE_CHECK(std::isfinite(share) && share >= 0.0f && share < 1.0f,
                "WeightPredictor::set_min_weight: share must be in [0, 1), got ", share);
  model_->min_weight = share;
}

character::SkinWeights WeightPredictor::predict(const character::Mesh& rest, const character::Skeleton& skeleton,
                                                int max_influences, const BindOptions& opt) {
  WeightOptions o;
  o.max_influences = max_influences;
  o.bind = opt;
  return predict(rest, skeleton, o);
}

character::SkinWeights WeightPredictor::predict(const character::Mesh& rest, const character::Skeleton& skeleton,
                                                const WeightOptions& opt, WeightReport* report) {
  GATCORE_CHECK(model_, "WeightPredictor::predict: no model loaded");
  const std::string& name = opt.bind.name;
  const character::Character ch = weight_character(rest, skeleton, name);
  GATCORE_CHECK(!model_->any || opt.bind.aliases.pairs.empty(), name,
                ": aliases have no effect with skinweights-any (it matches no bone names)");
  const int k = opt.max_influences;
  character::WeightPrediction p =
      model_->any ? character::predict_skin_weights_any(*model_->lm.model, model_->lm.norm, ch, k)
                  : character::predict_skin_weights(*model_->lm.model, model_->lm.norm, model_->bones, ch, k,
                                                    opt.bind.aliases);
  character::BoneHeatParams bp = opt.heat;
  bp.max_influences = k;
  const auto t0 = std::chrono::steady_clock::now();
  character::SkinWeights w = character::mix_with_bone_heat(ch, p.weights, model_->heat_blend, bp);
  const double heat_ms = model_->heat_blend > 0.0f ? ms_since(t0) : 0.0;
  if (model_->min_weight > 0.0f) w = character::limit_weights(w, k, model_->min_weight);
  if (report) {
    WeightReport r;
    if (model_->any) {
      r.mapped_joints = skeleton.num_joints();
    } else {
      r.mapped_joints = p.mapping.num_mapped();
      r.unmapped = p.mapping.unmapped;
      r.unseen_absent_bones = character::unseen_absent_bones(p.mapping, model_->bones, model_->presence);
      r.absent_bones_warning = character::unseen_absent_bones_warning(name, r.unseen_absent_bones, model_->presence);
    }
    r.features_ms = 1e3 * p.seconds_features;
    r.inference_ms = 1e3 * p.seconds_inference;
    r.bone_heat_ms = heat_ms;
    *report = std::move(r);
  }
  return w;
}

character::SkinWeights bone_heat_weights(const character::Mesh& rest, const character::Skeleton& skeleton,
                                         const character::BoneHeatParams& params, const std::string& name,
                                         WeightReport* report) {
  const character::Character ch = weight_character(rest, skeleton, name);
  const auto t0 = std::chrono::steady_clock::now();
  character::SkinWeights w = character::bone_heat_weights(ch, params);
  if (report) {
    *report = WeightReport{};
    report->mapped_joints = skeleton.num_joints();
    report->bone_heat_ms = ms_since(t0);
  }
  return w;
}

}  // namespace gatcore::runtime
