// `gat info FILE`: what a character, motion, dataset, point cache or model
// file holds (vertices, components, joints, influences per vertex, clips,
// model configuration and training state). Bad files exit non-zero with the
// reason.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cli_options.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/data/bone_candidate_samples.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/character/viz/loss_curve.hpp"
#include "progress.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/model_kind.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/precision.hpp"
#include "gatcore/train/training_run.hpp"

using namespace gatcore::character;

namespace gat {

namespace {

bool ends_with(const std::string& s, const char* suffix) {
  const std::size_t n = std::strlen(suffix);
  if (s.size() < n) return false;
  for (std::size_t i = 0; i < n; ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - n + i])) != suffix[i]) return false;
  return true;
}

void print_character(const Character& ch, const BoneAliases& aliases) {
  const Mesh& m = ch.mesh;
  const Skeleton& s = ch.skeleton;
  const Components comp = connected_components(m);
  std::printf("character  %s\n", ch.name.c_str());
  std::printf("vertices   %lld welded (%lld in the file, %zu primitives)\n", static_cast<long long>(m.num_vertices()),
              static_cast<long long>(ch.num_file_vertices()), ch.primitives.size());
  // Files that bind each mesh with its own skin, whose inverse bind matrices
  // disagree for the same joint (one skin per object, relative to the
  // object): the importer maps those meshes into one bind space. Said here
  // because it is the first thing to suspect when weights or bind poses
  // look off in another tool.
  {
    const Mat4 id = mat4_identity();
    int mapped = 0;
    double worst = 0;
    for (const SourcePrimitive& p : ch.primitives) {
      double d = 0;
      for (int i = 0; i < 16; ++i) d = std::max(d, std::abs(double(p.to_bind[i]) - double(id[i])));
      if (d > 1e-5) ++mapped, worst = std::max(worst, d);
    }
    if (mapped)
      std::printf("bind space %d of %zu primitives are bound by a skin whose inverse bind matrices differ from the "
                  "character's (largest matrix entry change %.3g): mapped into one bind space\n",
                  mapped, ch.primitives.size(), worst);
  }
  std::printf("triangles  %lld\n", static_cast<long long>(m.num_triangles()));
  std::printf("components %d\n", comp.count);
  std::vector<int> weighted(static_cast<std::size_t>(s.num_joints()), 0);
  for (std::int32_t j : m.weights.joint) weighted[j] = 1;
  int weightless = 0;
  for (int w : weighted) weightless += !w;
  std::printf("joints     %d (%d without weights)\n", s.num_joints(), weightless);
  // Influences per vertex histogram.
  const std::int64_t maxk = m.weights.max_influences();
  std::vector<long long> hist(static_cast<std::size_t>(maxk + 1), 0);
  for (std::int64_t v = 0; v < m.num_vertices(); ++v) ++hist[m.weights.ptr[v + 1] - m.weights.ptr[v]];
  std::printf("influences per vertex: mean %.2f, max %lld;",
              m.num_vertices() ? static_cast<double>(m.weights.joint.size()) / static_cast<double>(m.num_vertices()) : 0.0,
              static_cast<long long>(maxk));
  for (std::int64_t k = 1; k <= maxk; ++k) std::printf(" %lld:%lld", static_cast<long long>(k), hist[k]);
  std::printf("\n");
  std::printf("clips      %zu\n", ch.clips.size());
  for (const Clip& c : ch.clips)
    std::printf("  %-32s %5zu frames at %g fps (%.2f s)\n", c.name.c_str(), c.frames.size(), c.fps,
                c.frames.empty() ? 0.0 : (c.frames.size() - 1) / c.fps);
  std::printf("skeleton\n");
  std::vector<int> depth(static_cast<std::size_t>(s.num_joints()), 0);
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    depth[j] = s.parents[j] >= 0 ? depth[s.parents[j]] + 1 : 0;
    std::printf("  %3d %*s%s%s\n", j, 2 * depth[j], "", s.names[j].c_str(), weighted[j] ? "" : "  (no weights)");
  }
  // The rig convention and the body map retargeting uses.
  std::printf("%s", describe_rig(s, map_rig(s, aliases, compute_normalisation(ch).bind_to_world)).c_str());
}

void print_motion(const Motion& m, const BoneAliases& aliases) {
  const Skeleton& s = m.skeleton;
  std::printf("motion     %s\n", m.name.c_str());
  std::printf("joints     %d\n", s.num_joints());
  std::printf("clips      1\n  %-32s %5zu frames at %g fps (%.2f s)\n", m.clip.name.c_str(), m.clip.frames.size(),
              m.clip.fps, m.clip.frames.empty() ? 0.0 : (m.clip.frames.size() - 1) / m.clip.fps);
  std::printf("skeleton\n");
  std::vector<int> depth(static_cast<std::size_t>(s.num_joints()), 0);
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    depth[j] = s.parents[j] >= 0 ? depth[s.parents[j]] + 1 : 0;
    std::printf("  %3d %*s%s\n", j, 2 * depth[j], "", s.names[j].c_str());
  }
  std::printf("%s", describe_motion_rig(m, aliases).c_str());
}

void print_dataset(const std::string& path, const DatasetDescription& d) {
  std::printf("dataset    %s\n", path.c_str());
  std::printf("characters %zu (train %zu, validation %zu, test %zu; split by character, seed %u)\n", d.characters.size(),
              d.split.train.size(), d.split.validation.size(), d.split.test.size(), d.seed);
  for (std::size_t c = 0; c < d.characters.size(); ++c) {
    const char* part = "train";
    for (auto i : d.split.validation) part = static_cast<std::size_t>(i) == c ? "validation" : part;
    for (auto i : d.split.test) part = static_cast<std::size_t>(i) == c ? "test" : part;
    std::printf("  %-10s %s\n", part, d.characters[c].c_str());
  }
  std::printf("motions    %zu (every %d-th frame)\n", d.motions.size(), d.motion_stride);
  for (const auto& m : d.motions) std::printf("  %s\n", m.c_str());
  if (d.joint_limits)
    std::printf("poses      %d random per character per epoch, within joint limits '%s' (%zu rules)\n",
                d.random_poses, d.joint_limits->name.c_str(), d.joint_limits->rules.size());
  else
    std::printf("poses      %d random per character per epoch, +-%g rad per joint axis\n", d.random_poses, d.pose_angle);
  if (d.reference == ReferenceKind::arap)
    std::printf("reference  ARAP, %d iterations, handles at dominant weight >= %g\n", d.arap.iterations,
                double(d.arap.handle_weight));
  else
    std::printf("reference  Delta Mush, %d iterations, step %g\n", d.delta_mush.iterations, d.delta_mush.step);
  for (const FileTargetSource& t : d.targets)
    std::printf("targets    %s: %s driven by %s%s\n", d.characters[std::size_t(t.character)].c_str(), t.file.c_str(),
                t.motion.c_str(), t.first_frame ? (" from frame " + std::to_string(*t.first_frame)).c_str() : "");
  std::printf("subsample  %lld consecutive vertices per sample\n", static_cast<long long>(d.subsample));
  if (d.distortion_scales.empty())
    std::printf("features   DenseGATs: the paper's (posed position, normal, joint distances)\n");
  else
    std::printf("features   DenseGATs: the paper's + detail distortion at smoothing scales %s\n",
                format_distortion_scales(d.distortion_scales).c_str());
}

void print_point_cache(const std::string& path, const PointCache& pc) {
  std::printf("point cache %s\n", path.c_str());
  std::printf("points      %d\n", pc.num_points);
  std::printf("samples     %zu from frame %g, every %g frames\n", pc.samples.size(), pc.start_frame, pc.sample_rate);
  if (pc.samples.empty() || pc.num_points == 0) return;
  for (std::size_t s : {std::size_t{0}, pc.samples.size() - 1}) {
    float lo[3], hi[3];
    for (int c = 0; c < 3; ++c) lo[c] = hi[c] = pc.samples[s][c];
    for (std::size_t i = 0; i < pc.samples[s].size(); ++i)
      lo[i % 3] = std::min(lo[i % 3], pc.samples[s][i]), hi[i % 3] = std::max(hi[i % 3], pc.samples[s][i]);
    std::printf("  sample %-4zu bounds [%.4g %.4g %.4g] .. [%.4g %.4g %.4g]\n", s, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
  }
}

// A checkpoint: loading it fully checks the file (magic, checksum, every
// tensor against the configuration) before anything is printed; what it
// records is read by the library (model, trainer, run, model description).
void print_model(const std::string& path) {
  namespace models = gatcore::models;
  const models::LoadedModel l = models::load_checkpoint(path);
  const models::ModelConfig& c = l.model->config();
  const ModelDescription d = read_model_description(l.file, path);
  const models::TrainingProgress progress = models::read_training_progress(l.file, path);
  const gatcore::train::RunRecord run = gatcore::train::read_run_record(l.file, path);
  std::int64_t params = 0;
  for (const auto& p : l.model->parameters()) params += p.value().rows() * p.value().cols();
  std::printf("model      %s (%s), %lld parameters\n", c.name.c_str(),
              c.task == models::Task::weights ? "skin weights" : "displacement", static_cast<long long>(params));
  std::string features = feature_kind_name(d.features);
  if (d.nearest_joints > 0)
    features += ", joint columns " + format_joint_columns(d.nearest_joints) +
                " (each vertex's nearest joints: any skeleton)";
  if (!d.distortion_scales.empty())
    features += " + detail distortion at smoothing scales " + format_distortion_scales(d.distortion_scales);
  if (models::any_skeleton(c.kind())) {
    features += ignores_world_columns(l.norm)
                    ? "; the vertex's world-frame position and normal ignored (--world-columns ignore): the same "
                      "weights whichever way a character faces"
                    : "; reads the vertex's world-frame position and normal (--world-columns use)";
    features += std::string("; bone heat prior ") +
                (c.prior_weight_limit ? "with Blender's weight limit" : "without a weight limit") +
                (c.prior_straight_chains ? ", one bone per straight chain" : ", segments fanning to every child") +
                (c.prior_weight_limit && c.prior_straight_chains ? "" : " (a model from before these rules)");
  }
  std::printf("features   %lld in, %lld out (%s)\n", static_cast<long long>(c.in_dim), static_cast<long long>(c.out_dim),
              features.c_str());
  std::printf("config\n");
  const std::string cfg = c.to_text();
  for (std::size_t a = 0; a < cfg.size();) {
    const std::size_t b = std::min(cfg.find('\n', a), cfg.size());
    if (b > a) std::printf("  %s\n", cfg.substr(a, b - a).c_str());
    a = b + 1;
  }
  // The rate as the float the optimiser holds, shortest form (the metadata
  // keeps its double's 17 digits for an exact resume: 0.0010000000474974513).
  char lr_text[32] = "-";
  if (progress.lr >= 0) *std::to_chars(lr_text, lr_text + sizeof lr_text - 1, float(progress.lr)).ptr = '\0';
  std::printf("trained    %d epochs, lr %s, %lld Adam steps%s\n", progress.epoch, lr_text,
              static_cast<long long>(progress.adam_steps),
              progress.resumable ? " (resumable: optimiser state saved)" : "");
  if (progress.average_decay > 0)
    std::printf("averaged   the weights are their moving average over training (decay %g per step)\n",
                progress.average_decay);
  // Checkpoints from before gat train --precision trained in fp32.
  std::printf("precision  %s training products", gatcore::precision_name(run.precision));
  if (run.precision_requested != run.precision)
    std::printf(" (%s requested; this machine ran fp32)", gatcore::precision_name(run.precision_requested));
  std::printf("\n");
  if (models::any_skeleton(c.kind()))
    std::printf("weights    %s\n",
                d.postprocess ? ("calibrated (gat calibrate): " +
                                 (d.postprocess->heat_blend > 0
                                      ? "mixed with bone heat at " + number_text(double(d.postprocess->heat_blend)) + ", "
                                      : std::string()) +
                                 "influences below " + number_text(double(d.postprocess->min_weight)) + " dropped")
                                    .c_str()
                              : "the model's own top k (not calibrated: gat calibrate)");
  std::printf("data       %s", d.data.empty() ? "-" : d.data.c_str());
  if (!d.data_path.empty()) std::printf(" %s", d.data_path.c_str());
  std::printf("\n");
  if (!d.skeleton.empty()) {
    const std::string sk = joined_bone_names(d.skeleton);
    const bool nearest = d.nearest_joints > 0;
    std::printf("bones      %zu (%s%s)%s\n", d.skeleton.size(), sk.substr(0, 60).c_str(), sk.size() > 60 ? ", ..." : "",
                nearest ? ": the training data's skeleton, not matched (nearest-joint columns)" : "");
    const BonePresence& p = d.bone_presence;
    if (!nearest && !p.count.empty())
      std::printf("           %lld had by all %d training characters (a character lacking one gets a warning)\n",
                  static_cast<long long>(std::count(p.count.begin(), p.count.end(), p.characters)), p.characters);
  }
  if (!run.loss_history.empty()) {
    const auto h = parse_history(run.loss_history, path);
    if (!h.empty()) {
      std::printf("loss       %zu epochs recorded; last: train %.6g", h.size(), h.back().train);
      if (h.back().val >= 0) std::printf(", validation %.6g", h.back().val);
      if (h.back().val_l1 >= 0) std::printf(", validation L1 %.4f", h.back().val_l1);
      if (h.back().val_dominant >= 0) std::printf(", dominant bone right on %.1f %%", 100.0 * h.back().val_dominant);
      std::printf("\n");
      // Skin-weight runs: the epoch a --keep-best-by l1 checkpoint holds.
      const LossRecord* best = nullptr;
      for (const LossRecord& r : h)
        if (r.val_l1 >= 0 && (!best || r.val_l1 < best->val_l1)) best = &r;
      if (best) {
        std::printf("           lowest validation L1 %.4f at epoch %d", best->val_l1, best->epoch);
        if (best->val_dominant >= 0) std::printf(" (dominant bone right on %.1f %%)", 100.0 * best->val_dominant);
        std::printf("\n");
      }
    }
  }
}

}  // namespace

static int run_info(const std::string& path, const std::vector<std::string>& alias_specs) {
  Activity doing("reading " + path);
  BoneAliases aliases;  // --alias: the mapping the retargeter would use with it
  for (const auto& al : alias_specs) add_alias(aliases, al);
  if (ends_with(path, ".bvh") || ends_with(path, ".amc") || ends_with(path, ".asf") || path.find(".asf:") != std::string::npos ||
      path.find('#') != std::string::npos) {
    print_motion(load_motion(path), aliases);
    return 0;
  }
  if (ends_with(path, ".glb") || ends_with(path, ".gltf") || ends_with(path, ".fbx") || ends_with(path, ".dae")) {
    print_character(load_character(path), aliases);
    return 0;
  }
  if (ends_with(path, ".json")) {
    print_dataset(path, load_dataset(path));
    return 0;
  }
  if (ends_with(path, ".pc2")) {
    print_point_cache(path, read_point_cache(path));
    return 0;
  }
  if (ends_with(path, ".gcm") || ends_with(path, ".safetensors")) {
    print_model(path);
    return 0;
  }
  throw gatcore::InvalidArgument(path +
                                 ": unknown file type (expected .glb, .gltf, .fbx, .dae, .bvh, .amc, .pc2, .gcm / .safetensors or a dataset .json)");
}

Runner setup_info(CLI::App& gat) {
  auto path = std::make_shared<std::string>();
  auto aliases = std::make_shared<std::vector<std::string>>();
  CLI::App& c = add_command(gat, "info", "print what a character, motion, dataset, point cache or model file holds");
  c.add_option("FILE", *path,
               "a character (.glb / .gltf / .fbx / .dae), a motion (.bvh, .amc, SKELETON.asf:MOTION.amc, or CHARACTER#CLIP), a dataset (.json), a point cache (.pc2, "
               "as gat deform writes) or a model checkpoint (.gcm / .safetensors)")
      ->required();
  add_repeatable(c, "--alias", *aliases, "JOINT=BONE: map the joint JOINT onto BONE (a body part or a known joint name)");
  return [path, aliases] { return run_info(*path, *aliases); };
}

}  // namespace gat
