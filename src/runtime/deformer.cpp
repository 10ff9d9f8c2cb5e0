// runtime::Deformer: the per-frame computation of corrective.cpp's
// deform_frame (frame_features.hpp's pose_frame and feature functions) with
// every rest-pose quantity computed at bind() and every per-frame buffer
// allocated there too. pose_frame is shared (its into-buffer overload); the
// feature columns call the same functions (their into-buffer overloads) in
// the same order as densegats_frame_features / distortion_frame_features /
// features_in_bone_order, which keeps the numbers bitwise equal
// (test_runtime); those return new tensors, these write into the model's
// input buffer.
#include "gatcore/runtime.hpp"

#include <chrono>
#include <cmath>
#include <mutex>

#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/features/prepared_character.hpp"
#include "gatcore/character/rig/parallel.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/deploy.hpp"
#include "gatcore/vulkan.hpp"

namespace gatcore::runtime {

using namespace character;

Device resolve_device(DeviceChoice d) {
  switch (d) {
    case DeviceChoice::cpu: return Device::cpu;
    case DeviceChoice::automatic: return vulkan::select("auto");
    case DeviceChoice::vulkan: return vulkan::select("gpu");
  }
  return Device::cpu;
}

struct LoadedCorrective {
  std::shared_ptr<const models::DeployModel> model;
  std::vector<std::string> bones;
  std::vector<int> scales;
  int nearest = 0;  // > 0: joint columns = each vertex's K nearest joints (any skeleton, no mapping)
  BonePresence presence;  // bone columns: how many training characters had each bone
  std::string path;
};

namespace {
// The Vulkan backend records into one global command stream.
std::mutex& device_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

struct Deformer::Bound {
  PreparedCharacter pc;  // world frame (as gat deform)
  BoneMapping mapping;
  std::int64_t n = 0;
  std::int32_t J = 0;
  Mat4 inv_rest_root = mat4_identity();
  // Per-frame buffers.
  std::vector<Mat4> g;
  PosedFrame frame;  // pose_frame's result, its vectors sized at bind
  std::vector<float> smoothed, scratch, rest_skinned;
  std::vector<double> acc;
  std::vector<std::vector<float>> posed_details;
  std::vector<std::span<float>> posed_spans;
  Tensor features;  // [n, 6 + J]
  std::unique_ptr<models::DeployPlan> plan;
  FrameTiming timing;
};

Deformer::Deformer(std::shared_ptr<const LoadedCorrective> m) : model_(std::move(m)) {}
Deformer::Deformer(Deformer&&) noexcept = default;
Deformer& Deformer::operator=(Deformer&&) noexcept = default;
Deformer::~Deformer() = default;

Deformer Deformer::load(const std::string& path, DeviceChoice device, Precision precision) {
  return load(path, resolve_device(device), precision);
}

Deformer Deformer::load(const std::string& path, Device dev, Precision precision) {
  models::LoadedModel lm = models::load_checkpoint(path);
  auto m = std::make_shared<LoadedCorrective>();
  m->bones = character_model_bones(lm, path, models::Task::displacement);
  m->scales = checkpoint_distortion_scales(lm.file, path);
  m->nearest = checkpoint_nearest_joints(lm.file, path);
  if (m->nearest == 0) m->presence = checkpoint_bone_presence(lm.file, path, m->bones.size());
  GATCORE_CHECK(models::deployable(lm.model->config()), path, ": model '", lm.model->config().name,
                "' has no runtime path (densegats, densegats-noself, densegats-nodense, origat)");
  m->model = models::make_deploy_model(*lm.model, lm.norm, dev, precision);
  m->path = path;
  return Deformer(std::move(m));
}

Deformer Deformer::share() const { return Deformer(model_); }

void Deformer::bind(const Mesh& rest, const Skeleton& skeleton, const BindOptions& opt) {
  GATCORE_CHECK(model_, "Deformer::bind: no model loaded");
  bound_.reset();
  skeleton.validate((opt.name + " skeleton").c_str());
  rest.validate(skeleton.num_joints(), (opt.name + " mesh").c_str());
  GATCORE_CHECK(rest.num_vertices() > 0 && rest.num_triangles() > 0, opt.name, ": the mesh has no triangles");
  Character ch;
  ch.name = opt.name;
  ch.mesh = rest;
  ch.skeleton = skeleton;
  if (ch.skeleton.root_parent.size() != ch.skeleton.names.size())
    ch.skeleton.root_parent.assign(ch.skeleton.names.size(), mat4_identity());
  auto b = std::make_unique<Bound>();
  // As make_corrective_binding: no Delta Mush smoothing, only its one-ring
  // adjacency (distortion columns), the mesh graph and the normalisation.
  b->pc = prepare_character(ch, DeltaMushParams{0, 0.5f}, model_->scales);
  if (model_->nearest == 0) b->mapping = map_bones(ch.skeleton, model_->bones, opt.aliases, ch.name);
  const models::ModelConfig& cfg = models::deploy_config(*model_->model);
  const std::int64_t B = model_->nearest > 0 ? model_->nearest : std::int64_t(model_->bones.size()),
                     S = std::int64_t(model_->scales.size());
  GATCORE_CHECK(6 + B + 3 * S == cfg.in_dim, opt.name, ": ", 6 + B + 3 * S,
                " features (bones and distortion scales) for a model that takes ", cfg.in_dim);
  b->n = ch.mesh.num_vertices();
  b->J = ch.skeleton.num_joints();
  b->inv_rest_root = rest_root_inverse(b->pc);
  const std::size_t n3 = std::size_t(3 * b->n);
  b->g.resize(std::size_t(b->J));
  for (auto* v : {&b->smoothed, &b->scratch, &b->rest_skinned}) v->resize(n3);
  b->acc.resize(n3);
  pose_frame(b->pc, b->g = global_transforms(b->pc.character.skeleton, b->pc.rest), b->inv_rest_root, b->frame,
             b->acc);  // sizes every vector of the frame
  b->posed_details.assign(std::size_t(S), std::vector<float>(n3));
  b->posed_spans.assign(b->posed_details.begin(), b->posed_details.end());
  b->features = Tensor::empty(b->n, 6 + b->J);
  b->plan = std::make_unique<models::DeployPlan>(model_->model, gatcore::share(CsrGraph(b->pc.mesh_graph)));
  bound_ = std::move(b);
}

bool Deformer::bound() const { return bound_ != nullptr; }
std::int64_t Deformer::num_vertices() const { return bound_ ? bound_->n : 0; }
std::int32_t Deformer::num_joints() const { return bound_ ? bound_->J : 0; }
FrameTiming Deformer::last_timing() const { return bound_ ? bound_->timing : FrameTiming{}; }
const std::string& Deformer::model_name() const { return models::deploy_config(*model_->model).name; }
const std::vector<std::string>& Deformer::bones() const { return model_->bones; }
std::int64_t Deformer::parameter_count() const { return models::deploy_parameter_count(*model_->model); }
Device Deformer::device() const { return models::deploy_device(*model_->model); }
Precision Deformer::precision() const { return models::deploy_precision(*model_->model); }
std::vector<std::string> Deformer::unseen_absent_bones() const {
  if (!bound_ || model_->nearest > 0) return {};
  return character::unseen_absent_bones(bound_->mapping, model_->bones, model_->presence);
}
std::string Deformer::absent_bones_warning() const {
  if (!bound_) return "";
  return unseen_absent_bones_warning(bound_->pc.character.name, unseen_absent_bones(), model_->presence);
}
int Deformer::nearest_joints() const { return model_->nearest; }
const Skeleton& Deformer::bound_skeleton() const {
  GATCORE_CHECK(bound_, "Deformer::bound_skeleton: bind() a character first");
  return bound_->pc.character.skeleton;
}
std::int32_t Deformer::mapped_joints() const {
  if (!bound_) return 0;
  return model_->nearest > 0 ? bound_->J : bound_->mapping.num_mapped();
}

void Deformer::deform(std::span<const float> joint_globals, std::span<float> out, std::span<float> out_normals,
                      std::span<float> out_lbs) {
  GATCORE_CHECK(bound_, "Deformer::deform: bind() a character first");
  Bound& b = *bound_;
  const PreparedCharacter& pc = b.pc;
  const Mesh& mesh = pc.character.mesh;
  const std::size_t n3 = std::size_t(3 * b.n);
  GATCORE_CHECK(joint_globals.size() == std::size_t(16 * b.J), pc.character.name, ": deform got ",
                joint_globals.size(), " floats of joint transforms, expected 16 per joint (", b.J, " joints)");
  GATCORE_CHECK(out.size() == n3, pc.character.name, ": deform's output has ", out.size(), " floats, expected 3 per vertex (",
                b.n, " vertices)");
  GATCORE_CHECK(out_normals.empty() || out_normals.size() == n3, pc.character.name, ": deform's normals output has ",
                out_normals.size(), " floats, expected ", n3);
  GATCORE_CHECK(out_lbs.empty() || out_lbs.size() == n3, pc.character.name, ": deform's LBS output has ",
                out_lbs.size(), " floats, expected ", n3);
  for (std::size_t i = 0; i < joint_globals.size(); ++i)
    GATCORE_CHECK(std::isfinite(joint_globals[i]), pc.character.name, ": joint ", i / 16, " (",
                  pc.character.skeleton.names[i / 16], ") has a non-finite transform entry");
  std::unique_lock<std::mutex> device_lock;
  if (device() != Device::cpu) device_lock = std::unique_lock<std::mutex>(device_mutex());
  const auto t0 = std::chrono::steady_clock::now();

  for (std::int32_t j = 0; j < b.J; ++j) std::copy_n(joint_globals.data() + 16 * j, 16, b.g[std::size_t(j)].begin());
  PosedFrame& fr = b.frame;
  pose_frame(pc, b.g, b.inv_rest_root, fr, b.acc);
  const Mat4& to_root = fr.to_root;
  const std::int64_t n = b.n;
  densegats_features(fr.lbs_root, fr.normals, fr.joints, b.features);  // densegats_frame_features, whole mesh

  // The model's input: features_in_bone_order, then the distortion columns
  // (densegats_model_features).
  const Tensor& x = b.plan->input();
  const int K = model_->nearest;
  const std::int64_t B = K > 0 ? K : std::int64_t(b.mapping.bone_to_joint.size()), f = 6 + B;
  x.cols_slice(0, f).zero_();
  for (std::int64_t i = 0; i < n; ++i) {
    const float* src = b.features.row(i);
    float* dst = x.row(i);
    for (int c = 0; c < 6; ++c) dst[c] = src[c];
    if (K > 0) {
      nearest_joint_distances(src + 6, b.J, K, dst + 6);  // nearest_joint_columns
      continue;
    }
    for (std::int32_t j = 0; j < b.J; ++j)
      if (b.mapping.joint_to_bone[std::size_t(j)] >= 0) dst[6 + b.mapping.joint_to_bone[std::size_t(j)]] = src[6 + j];
  }
  if (!pc.distortion_scales.empty()) {
    // distortion_frame_features / detail_halves: posed details of the root-frame LBS mesh; rest details
    // carried by the skinning, turned into the root frame and normalised.
    laplacian_details(pc.delta_mush, fr.lbs_root, pc.distortion_scales, b.posed_spans, b.smoothed, b.scratch);
    for (std::size_t k = 0; k < pc.rest_details.size(); ++k) {
      skin_vectors(mesh, fr.skinning, pc.rest_details[k], b.rest_skinned);
      const std::vector<float>& posed = b.posed_details[k];
      for (std::int64_t v = 0; v < n; ++v) {
        const float* a = &b.rest_skinned[std::size_t(3 * v)];
        const float ax = a[0], ay = a[1], az = a[2];
        float* dst = x.row(v) + f + 3 * std::int64_t(k);
        for (int c = 0; c < 3; ++c) {
          const float r = (to_root[c] * ax + to_root[4 + c] * ay + to_root[8 + c] * az) * pc.normalisation.scale;
          dst[c] = r - posed[std::size_t(3 * v + c)];
        }
      }
    }
  }
  const auto t1 = std::chrono::steady_clock::now();
  const Tensor& y = b.plan->run();
  const auto t2 = std::chrono::steady_clock::now();

  // deform_frame: normalised units back to the character's; the model
  // predicts in the root frame (root_offset_to_world).
  const float inv = 1.0f / pc.normalisation.scale;
  std::int64_t bad = -1;
  for (std::int64_t v = 0; v < n; ++v) {
    const Vec3 o = root_offset_to_world(fr.root_motion, {y.at(v, 0), y.at(v, 1), y.at(v, 2)});
    for (int c = 0; c < 3; ++c) {
      const float l = fr.lbs[std::size_t(3 * v + c)] * inv + pc.normalisation.origin[std::size_t(c)];
      const float off = o[std::size_t(c)] * inv;
      if (!std::isfinite(off) && bad < 0) bad = v;
      if (!out_lbs.empty()) out_lbs[std::size_t(3 * v + c)] = l;
      out[std::size_t(3 * v + c)] = l + off;
    }
  }
  GATCORE_CHECK(bad < 0, pc.character.name, ": the model predicted a non-finite offset at vertex ", bad);
  if (!out_normals.empty()) vertex_normals(out, mesh.triangles, out_normals, b.acc);
  const auto t3 = std::chrono::steady_clock::now();
  b.timing.features_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  b.timing.model_ms = std::chrono::duration<double, std::milli>(t2 - t1).count();
  b.timing.total_ms = std::chrono::duration<double, std::milli>(t3 - t0).count();
}

}  // namespace gatcore::runtime
