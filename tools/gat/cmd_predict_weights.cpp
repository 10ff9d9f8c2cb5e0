// `gat predict-weights MODEL in.glb -o out.glb [--max-influences K]`: skin
// weights for a character from a trained NeuroSkinning-family checkpoint (or
// `--method bone-heat`, the classical baseline, without a model), written into
// a copy of the file with everything else kept. The prediction is the
// runtime's (runtime::WeightPredictor, runtime::bone_heat_weights): an engine
// gets the tool's weights.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/error.hpp"
#include "gatcore/runtime.hpp"
#include "progress.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace gat {

namespace {

struct PredictArgs {
  std::vector<std::string> positional;  // [MODEL] CHARACTER
  std::string out, method = "model";
  long k = 4;
  double min_weight = -1;  // < 0: the method's default
  double heat_blend = -1;  // a model's weights mixed with bone heat's at this share; < 0: the model's default
  std::vector<std::string> aliases;
  std::vector<std::string> bones, controls;  // bone heat: joints forced to be bones / controls
  CommonOptions common;
};

// Joints the written weights never name: said, never silent, since a limb
// on such a joint stays in the bind pose when the rig animates it.
void print_weightless_joints(const Character& ch, const SkinWeights& w, const char* why) {
  std::vector<std::uint8_t> used(static_cast<std::size_t>(ch.skeleton.num_joints()), 0);
  for (std::int32_t j : w.joint) used[static_cast<std::size_t>(j)] = 1;
  std::string names;
  int count = 0;
  for (std::int32_t j = 0; j < ch.skeleton.num_joints(); ++j)
    if (!used[static_cast<std::size_t>(j)] && count++ < 8) names += (names.empty() ? "" : ", ") + ch.skeleton.names[j];
  if (count > 0)
    std::printf("  %d of %d joints get no weight (%s): %s%s\n", count, ch.skeleton.num_joints(), why, names.c_str(),
                count > 8 ? ", ..." : "");
}

// Bone heat's settings for CHARACTER: top k and the user's --bone / --control
// joints (checked by name); min weight bone heat's default, 0.01.
BoneHeatParams heat_params(const PredictArgs& a, const Character& ch, const std::string& in) {
  BoneHeatParams bp;
  const auto mark = [&](const std::vector<std::string>& names, std::int8_t value, const char* flag) {
    for (const std::string& name : names) {
      const std::int32_t j = ch.skeleton.find(name);
      GATCORE_CHECK(j >= 0, in, ": ", flag, " ", name, ": the character has no joint of that name");
      GATCORE_CHECK(bp.joint_override[static_cast<std::size_t>(j)] == 0, in, ": joint ", name,
                    " is given both --bone and --control");
      bp.joint_override[static_cast<std::size_t>(j)] = value;
    }
  };
  if (!a.bones.empty() || !a.controls.empty()) {
    bp.joint_override.assign(static_cast<std::size_t>(ch.skeleton.num_joints()), 0);
    mark(a.bones, 1, "--bone");
    mark(a.controls, -1, "--control");
  }
  bp.max_influences = int(a.k);
  return bp;
}

// "  influences per vertex: mean M, max X (limit K<limits>)" (no newline).
void print_influences(const SkinWeights& w, long k, const std::string& limits = "") {
  std::printf("  influences per vertex: mean %.2f, max %lld (limit %ld%s)",
              double(w.joint.size()) / double(std::max<std::int64_t>(1, w.num_vertices())),
              static_cast<long long>(w.max_influences()), k, limits.c_str());
}

int run(const PredictArgs& a) {
  const bool heat = a.method == "bone-heat";
  const std::size_t want = heat ? 1 : 2;
  // Checked here rather than by CLI11: MODEL is absent with --method bone-heat.
  if (a.positional.size() < want) throw CLI::RequiredError(a.positional.empty() && !heat ? "MODEL" : "CHARACTER");
  if (a.positional.size() > want) throw CLI::ExtrasError({a.positional.back()});
  if (a.out.empty()) throw CLI::RequiredError("--out");
  const std::string model_path = heat ? std::string() : a.positional[0], in = a.positional.back(), &out = a.out;
  const long k = a.k;
  runtime::WeightOptions opt;
  opt.max_influences = int(k);
  opt.bind.name = in;
  for (const auto& al : a.aliases) add_alias(opt.bind.aliases, al);
  GATCORE_CHECK(is_gltf_path(in), in, ": predict-weights reads glTF characters (.glb / .gltf)");
  GATCORE_CHECK(is_gltf_path(out), out, ": the output must be a .glb or .gltf file");
  const std::filesystem::path dir = std::filesystem::path(out).parent_path();
  GATCORE_CHECK(dir.empty() || std::filesystem::is_directory(dir), out, ": the directory ", dir.string(),
                " does not exist");
  apply_threads(a.common);
  // The steps of a prediction, one progress line (a large character's
  // features and solve take seconds).
  Progress progress("predict-weights " + in, heat ? 3 : 4, "steps", a.common.quiet);
  progress.set_stages();
  int step = 0;
  const auto stage = [&](const char* what) { progress.update(step++, what); };
  runtime::WeightReport report;
  if (heat) {
    GATCORE_CHECK(opt.bind.aliases.pairs.empty(),
                  "--alias has no effect with --method bone-heat (no model bones to match)");
    GATCORE_CHECK(a.heat_blend < 0, "--heat-blend mixes a model's weights with bone heat's; with --method "
                                     "bone-heat there is no model");
    stage("reading the character");
    const Character ch = load_gltf(in);
    BoneHeatParams bp = heat_params(a, ch, in);
    if (a.min_weight >= 0) bp.min_weight = float(a.min_weight);
    Activity doing("computing the bone-heat weights of " + in);
    stage("bone heat: visibility and heat diffusion");
    const SkinWeights w = runtime::bone_heat_weights(ch.mesh, ch.skeleton, bp, in, &report);
    stage("writing");
    save_gltf_with_weights(in, ch, w, out, int(k));
    progress.finish();
    std::printf("gat predict-weights: bone heat on %s: %lld vertices welded (%lld in the file), %d joints\n",
                in.c_str(), static_cast<long long>(ch.mesh.num_vertices()),
                static_cast<long long>(ch.num_file_vertices()), ch.skeleton.num_joints());
    char min_weight[64];
    std::snprintf(min_weight, sizeof min_weight, ", min weight %.3g", double(bp.min_weight));
    print_influences(w, k, min_weight);
    std::printf("; %.1f ms -> %s\n", report.bone_heat_ms, out.c_str());
    print_weightless_joints(ch, w, "controls outside the mesh, or no vertex's nearest bone");
    return 0;
  }
  const Device dev = device_from_flag(a.common.device, "predict-weights");
  Activity reading("reading the checkpoint " + model_path);
  stage("reading the checkpoint");
  runtime::WeightPredictor predictor = runtime::WeightPredictor::load(model_path, dev);
  // Skeleton-agnostic (skinweights-any): each vertex's own nearest bones, no names to match.
  const bool any = predictor.any_skeleton();
  GATCORE_CHECK(!any || opt.bind.aliases.pairs.empty(),
                "--alias has no effect with skinweights-any (it matches no bone names)");
  if (a.heat_blend >= 0) predictor.set_heat_blend(float(a.heat_blend));
  if (a.min_weight >= 0) predictor.set_min_weight(float(a.min_weight));
  GATCORE_CHECK(predictor.heat_blend() > 0 || (a.bones.empty() && a.controls.empty()),
                "--bone and --control only apply to bone heat (--method bone-heat, or a model's heat blend); a model "
                "scores every joint itself");
  stage("reading the character");
  const Character ch = load_gltf(in);
  if (predictor.heat_blend() > 0) opt.heat = heat_params(a, ch, in);
  Activity doing("predicting the skin weights of " + in);
  stage("features and inference");
  const SkinWeights w = predictor.predict(ch.mesh, ch.skeleton, opt, &report);
  stage("writing");
  save_gltf_with_weights(in, ch, w, out, int(k));
  progress.finish();

  if (any) {
    std::printf("gat predict-weights: skinweights-any (%s, %lld candidate bones per vertex) on %s, device %s\n",
                model_path.c_str(), static_cast<long long>(predictor.candidates_per_vertex()), in.c_str(),
                device_label(dev).c_str());
    std::printf("  %lld vertices welded (%lld in the file), %d joints\n", static_cast<long long>(ch.mesh.num_vertices()),
                static_cast<long long>(ch.num_file_vertices()), ch.skeleton.num_joints());
  } else {
    std::printf("gat predict-weights: %s (%s, %zu bones) on %s, device %s\n", predictor.model_name().c_str(),
                model_path.c_str(), predictor.bones().size(), in.c_str(), device_label(dev).c_str());
    std::printf("  %lld vertices welded (%lld in the file), %d joints: %d matched to the model's bones",
                static_cast<long long>(ch.mesh.num_vertices()), static_cast<long long>(ch.num_file_vertices()),
                ch.skeleton.num_joints(), report.mapped_joints);
    if (!report.unmapped.empty()) {
      std::string names;
      for (std::size_t j = 0; j < report.unmapped.size() && j < 8; ++j) names += (j ? ", " : "") + report.unmapped[j];
      std::printf(", %zu without a bone get no weight (%s%s)", report.unmapped.size(), names.c_str(),
                  report.unmapped.size() > 8 ? ", ..." : "");
    }
    std::printf("\n");
  }
  if (predictor.heat_blend() > 0)
    std::printf("  mixed with bone heat: (1 - %g) * model + %g * bone heat per vertex, top %ld kept\n",
                double(predictor.heat_blend()), double(predictor.heat_blend()), k);
  if (predictor.min_weight() > 0)
    std::printf("  influences below %g of the vertex's total dropped, the rest renormalised\n",
                double(predictor.min_weight()));
  print_influences(w, k);
  std::printf("\n  features %.1f ms, inference %.1f ms -> %s\n", report.features_ms, report.inference_ms, out.c_str());
  if (any)
    print_weightless_joints(ch, w, "no vertex's candidate, or scored below the kept influences");
  else
    warn_absent_bones("gat predict-weights", report.absent_bones_warning,
                      "predict with a skinweights-any model or --method bone-heat (any skeleton)");
  return 0;
}

}  // namespace

Runner setup_predict_weights(CLI::App& gat) {
  auto a = std::make_shared<PredictArgs>();
  CLI::App& c = add_command(gat, "predict-weights", "skin weights for a character from a NeuroSkinning-family model");
  set_details(c, "Predicts skin weights for CHARACTER (.glb/.gltf) with a skin-weight checkpoint (neuroskinning, "
                "neuroskinning-nopool, pointnet, fc; trained with gat train --data) and writes the file again with "
                "the new weights, everything else kept. The model's bones are matched to the character's joints by "
                "normalised name (\"LeftArm\" = \"Arm.L\" = \"arm.l\"); joints without a match get no weight. skinweights-any checkpoints work on any skeleton (each vertex's own "
                 "nearest bones; no names).");
  c.add_option("MODEL CHARACTER", a->positional,
               "a skin-weight checkpoint (.gcm; not with --method bone-heat) and the character (.glb / .gltf)")
      ->expected(1, 2);
  c.add_option("--method", a->method,
               "model (default) or bone-heat: Baran & Popovic's heat diffusion from the nearest visible bone "
               "(Blender's automatic weights), on any skeleton, no model")
      ->check(one_of({"model", "bone-heat"}));
  c.add_option("--min-weight", a->min_weight,
               "drop influences below W of the vertex's total, renormalise (default: a model's calibrated value "
               "(gat calibrate), else 0; bone heat 0.01; artists often use about 2 influences)")
      ->check(number_in(0, 0.999));
  c.add_option("--heat-blend", a->heat_blend,
               "S in [0, 1]: mix the model's weights with bone heat's, (1 - S) * model + S * bone heat per vertex, "
               "then keep the largest --max-influences (default: the model's calibrated share (gat calibrate), else "
               "0, the model alone). A hedge for a character unlike "
               "every family the model was trained on: 0.3 lowered L1 on the unseen creatures and Khronos rigs "
               "and cost on characters like the training ones (docs/RESULTS.md)")
      ->check(number_in(0, 1));
  add_out(c, a->out, "the character with the predicted weights (.glb / .gltf; required)");
  c.add_option("--max-influences", a->k,
               "bones kept per vertex, renormalised (4: what engines expect; more are written as "
               "JOINTS_1/WEIGHTS_1, ...)")
      ->check(int_in(1, 64))->capture_default_str();
  add_repeatable(c, "--alias", a->aliases, "JOINT=BONE: treat the character's joint JOINT as the model's bone BONE");
  add_repeatable(c, "--bone", a->bones,
                 "JOINT: with --method bone-heat (or --heat-blend), JOINT is a bone even where it looks like a "
                 "control (a joint outside the mesh)");
  add_repeatable(c, "--control", a->controls,
                 "JOINT: with --method bone-heat (or --heat-blend), bone heat gives JOINT no weight (an IK target, "
                 "a helper the rules keep)");
  add_device(c, a->common);
  add_threads(c, a->common);
  add_quiet(c, a->common);
  return [a] { return run(*a); };
}

}  // namespace gat
