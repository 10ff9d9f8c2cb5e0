#pragma once
// gatcore's runtime: a trained model inside an engine or DCC plugin, every
// frame, on the character being posed. (gatcore.h is the C API over it.)
//
//   auto d = gatcore::runtime::Deformer::load("corrective.gcm");
//   d.bind(rest_mesh, skeleton);               // once: everything that depends on the rest pose
//   for each frame:
//     d.deform(joint_globals, positions);      // LBS + the model's correction, into caller memory
//
// Deformer: a displacement checkpoint (densegats, its ablations, origat)
// applied to one character. bind() computes everything that depends only on
// the rest pose (normalisation, the mesh graph, the smoothing adjacency and
// rest details of the distortion columns, the bone mapping) and allocates
// every per-frame buffer and the model's workspace (models::DeployPlan);
// deform() then allocates nothing on the CPU (tested) and gives exactly
// the numbers of the character layer's per-frame path (deform_frame, tested
// bitwise); `gat deform` is this class. One Deformer per character; the
// loaded model is immutable and shared by share(), so characters can be
// deformed from different threads at once (CPU; the Vulkan backend is one
// command stream: deformers on Vulkan are serialised internally).
//
// Frames: joint_globals[j] is joint j's joint-to-model-space matrix
// (column-major 4x4, as character::global_transforms gives for a pose; in an
// engine: the bone's transform relative to the skinned mesh's root). Output
// positions are in the same space as linear blend skinning with those
// matrices and the skeleton's inverse bind matrices.
//
// WeightPredictor: a skin-weight checkpoint (neuroskinning, ..., fc,
// pointnet, matched to the skeleton by joint name; or skinweights-any, any
// skeleton, no names) predicting a new character's skin weights (a one-off
// per character, not per frame: it allocates), optionally mixed with bone
// heat's (set_heat_blend, as gat predict-weights --heat-blend).
// bone_heat_weights: the same without a model (gat predict-weights
// --method bone-heat). gat predict-weights and gat deform are these calls
// with file import / export around them.
//
// Errors: gatcore::Error (InvalidArgument for bad input) with a message
// naming the argument / file / value. No dependency on datasets, importers
// or training code.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/rig/mesh.hpp"
#include "gatcore/character/rig/skeleton.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/precision.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::runtime {

// Where a model runs. automatic: the Vulkan device when this build has the
// backend and a GPU is found (vulkan::select("auto")), else the CPU.
enum class DeviceChoice { cpu, automatic, vulkan };
Device resolve_device(DeviceChoice d);
// The loaders take a DeviceChoice, or a Device the caller has already
// selected (a vulkan::select spec of its own, as gat's --device).

struct LoadedCorrective;  // the immutable loaded model (shared)

struct BindOptions {
  // The character's joint names -> the model's bone names (as gat deform --alias).
  character::BoneAliases aliases;
  std::string name = "character";  // for messages
};

// Timings of the last deform() (milliseconds).
struct FrameTiming {
  double features_ms = 0, model_ms = 0, total_ms = 0;
};

class Deformer {
 public:
  // Loads a displacement checkpoint. Throws naming the file for a missing /
  // corrupt file or a model that does not predict displacements.
  // precision: of the model's products (gatcore/precision.hpp). fp32 gives
  // gat deform's numbers bitwise; bf16 (CPU device, AVX512_BF16 CPUs only:
  // bf16_supported(); InvalidArgument otherwise) about twice the products'
  // speed, at an offset error of ~0.5 % of the correction (bench/RESULTS.md).
  static Deformer load(const std::string& checkpoint, DeviceChoice device = DeviceChoice::cpu,
                       Precision precision = Precision::fp32);
  static Deformer load(const std::string& checkpoint, Device device, Precision precision = Precision::fp32);
  // A new, unbound deformer sharing this one's loaded model.
  Deformer share() const;
  Deformer(Deformer&&) noexcept;
  Deformer& operator=(Deformer&&) noexcept;
  ~Deformer();

  // The rest mesh (bind-space positions, triangles, skin weights on the
  // skeleton's joints) and its skeleton (names, parents, rest local
  // transforms, inverse bind matrices). Both are checked (validate());
  // rebinding replaces the previous character.
  void bind(const character::Mesh& rest, const character::Skeleton& skeleton, const BindOptions& opt = {});
  bool bound() const;
  std::int64_t num_vertices() const;  // of the bound mesh
  std::int32_t num_joints() const;
  // joint_globals: [num_joints]; out_positions: [3 num_vertices]; out_normals
  // (optional, empty span = not wanted): [3 num_vertices] unit area-weighted
  // normals of the corrected mesh. `out_lbs` (optional): the plain linear
  // blend skinning positions, for comparison.
  void deform(std::span<const float> joint_globals, std::span<float> out_positions,
              std::span<float> out_normals = {}, std::span<float> out_lbs = {});
  FrameTiming last_timing() const;

  // The model: name ("densegats", ...), its bones, its parameter count, where it runs.
  const std::string& model_name() const;
  const std::vector<std::string>& bones() const;
  std::int64_t parameter_count() const;
  Device device() const;
  Precision precision() const;
  // Joints of the bound character that matched a model bone (a model with
  // nearest-joint columns uses every joint, whatever its name: all of them).
  std::int32_t mapped_joints() const;
  // The model's bones the bound character lacks although every training
  // character had them (character::unseen_absent_bones): inputs the model
  // never saw, worth a warning to the user (gat deform prints one); bind's
  // aliases can map joints onto them. Empty for nearest-joint models, for
  // checkpoints that do not record their training bones, and before bind.
  std::vector<std::string> unseen_absent_bones() const;
  // The warning naming them (character::unseen_absent_bones_warning, with
  // how many training characters had each), "" when there are none.
  std::string absent_bones_warning() const;
  // > 0: the model's joint columns are each vertex's K nearest joints (any
  // skeleton, no names matched); 0: bone columns matched by name.
  int nearest_joints() const;
  // The bound skeleton as deform() reads joint transforms: bind's names,
  // parents and rest transforms, its inverse bind matrices in the frame the
  // features are computed in (the rest mesh turned by its root's bind
  // transform). Poses for deform() are poses of this skeleton (a motion
  // retargeted onto it, as gat deform does). Throws before bind.
  const character::Skeleton& bound_skeleton() const;

 private:
  struct Bound;
  explicit Deformer(std::shared_ptr<const LoadedCorrective> m);
  std::shared_ptr<const LoadedCorrective> model_;
  std::unique_ptr<Bound> bound_;
};

struct LoadedWeights;

// What a weight prediction matched and how long it took (milliseconds).
struct WeightReport {
  // Joints matched to a model bone (every joint for skinweights-any and
  // bone heat) and the names of those without one (they get no weight).
  std::int32_t mapped_joints = 0;
  std::vector<std::string> unmapped;
  // As Deformer::unseen_absent_bones / absent_bones_warning, for a
  // name-matched model.
  std::vector<std::string> unseen_absent_bones;
  std::string absent_bones_warning;
  double features_ms = 0, inference_ms = 0;
  double bone_heat_ms = 0;  // bone heat's own weights (bone_heat_weights, or the heat blend's)
};

// A prediction's settings for one character.
struct WeightOptions {
  int max_influences = 4;  // kept per vertex (largest), renormalised
  BindOptions bind;        // aliases (name-matched models only) and the name for messages
  // The bone heat set_heat_blend mixes in: its joints forced to be bones /
  // controls (joint_override, as gat predict-weights --bone / --control),
  // its own min weight (0.01), ...; max_influences above replaces its own.
  character::BoneHeatParams heat;
};

class WeightPredictor {
 public:
  static WeightPredictor load(const std::string& checkpoint, DeviceChoice device = DeviceChoice::cpu);
  static WeightPredictor load(const std::string& checkpoint, Device device);
  WeightPredictor(WeightPredictor&&) noexcept;
  WeightPredictor& operator=(WeightPredictor&&) noexcept;
  ~WeightPredictor();
  // Skin weights on the skeleton's joints for the mesh's vertices (the mesh's
  // own weights, if any, are ignored), at most `max_influences` per vertex.
  // Not thread-safe on one predictor (the model runs in place); use one per thread.
  character::SkinWeights predict(const character::Mesh& rest, const character::Skeleton& skeleton,
                                 int max_influences = 4, const BindOptions& opt = {});
  // The same with every setting; `report` (optional) receives what was
  // matched and the timings.
  character::SkinWeights predict(const character::Mesh& rest, const character::Skeleton& skeleton,
                                 const WeightOptions& opt, WeightReport* report = nullptr);
  // Later predictions mix the model's weights with bone heat's:
  // (1 - share) * model + share * bone heat per vertex, the largest
  // max_influences kept. A hedge for a character unlike every family the
  // model was trained on (docs/RESULTS.md). Default: the share calibrated
  // into the checkpoint (gat calibrate), else 0 (the model alone). Throws
  // unless share is in [0, 1].
  void set_heat_blend(float share);
  float heat_blend() const;
  // Later predictions drop influences below `share` of the vertex's total
  // and renormalise, after the heat blend (as gat predict-weights
  // --min-weight). Default: the value calibrated into the checkpoint (gat
  // calibrate), else 0 (none). Throws unless share is in [0, 1).
  void set_min_weight(float share);
  float min_weight() const;
  // The bone names a name-matched model was trained on; empty for
  // skinweights-any (it takes any skeleton).
  const std::vector<std::string>& bones() const;
  // skinweights-any: each vertex scores its own nearest bones
  // (candidates_per_vertex of them), whatever the skeleton.
  bool any_skeleton() const;
  std::int64_t candidates_per_vertex() const;  // 0 for a name-matched model
  const std::string& model_name() const;       // "neuroskinning", ...
  Device device() const;

 private:
  explicit WeightPredictor(std::unique_ptr<LoadedWeights> m);
  std::unique_ptr<LoadedWeights> model_;
};

// Bone heat's skin weights (Baran & Popovic's heat diffusion from the
// nearest visible bone, Blender's automatic weights) for the rest mesh on
// any skeleton, no model: character::bone_heat_weights on them. As
// WeightPredictor::predict, the mesh's own weights are ignored; `name` is
// for messages; `report` (optional) gets the time (bone_heat_ms) and every
// joint as mapped.
character::SkinWeights bone_heat_weights(const character::Mesh& rest, const character::Skeleton& skeleton,
                                         const character::BoneHeatParams& params = {},
                                         const std::string& name = "character", WeightReport* report = nullptr);

}  // namespace gatcore::runtime
