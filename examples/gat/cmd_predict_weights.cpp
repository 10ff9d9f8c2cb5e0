// `gat predict-weights MODEL in.glb -o out.glb [--max-influences K]`: skin
// weights for a character from a trained NeuroSkinning-family checkpoint (or
// `--method bone-heat`, the classical baseline, without a model), written into
// a copy of the file with everything else kept.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <omp.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/inference/weight_prediction.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace gat {

namespace {

void usage(std::FILE* f) {
  std::fprintf(f,
               "usage: gat predict-weights MODEL CHARACTER.glb -o OUT.glb [--max-influences K] [--min-weight W]\n"
               "                           [--alias JOINT=BONE ...] [--device cpu|vulkan|auto] [--threads T]\n"
               "       gat predict-weights --method bone-heat CHARACTER.glb -o OUT.glb [--max-influences K] [--min-weight W]\n"
               "  Predicts skin weights for CHARACTER (.glb/.gltf) with a skin-weight checkpoint (neuroskinning,\n"
               "  neuroskinning-nopool, pointnet, fc; trained with gat train --data) and writes the file again\n"
               "  with the new weights, everything else kept. The model's bones are matched to the character's\n"
               "  joints by normalised name (\"LeftArm\" = \"Arm.L\" = \"arm.l\"); joints without a match get no weight.\n"
               "  --max-influences K  bones kept per vertex, renormalised (default 4, what engines expect; more\n"
               "                      are written as JOINTS_1/WEIGHTS_1, ...)\n"
               "  --min-weight W      drop influences below W of the vertex's total, renormalise (default 0 for a\n"
               "                      model, 0.01 for bone heat; artists often use about 2 influences)\n"
               "  skinweights-any checkpoints work on any skeleton (each vertex's own nearest bones; no names).\n"
               "  --method M          model (default) or bone-heat: Baran & Popovic's heat diffusion from the\n"
               "                      nearest visible bone (Blender's automatic weights), on any skeleton, no model\n"
               "  --alias JOINT=BONE  treat the character's joint JOINT as the model's bone BONE (repeatable)\n"
               "  --device D          where the model runs (cpu default; see gat train --help)\n");
}

double parse_double(const std::string& flag, const std::string& v, double lo, double hi) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || *end || !(x >= lo && x <= hi))
    throw InvalidArgument(flag + " expects a number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                          "], got '" + v + "'");
  return x;
}

}  // namespace

int cmd_predict_weights(int argc, char** argv) {
  std::string in, out, device = "cpu", method = "model";
  std::vector<std::string> positional;
  long k = 4, threads = 0;
  double min_weight = -1;
  BoneAliases aliases;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw InvalidArgument(a + " expects a value");
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      usage(stdout);
      return 0;
    } else if (a == "-o") {
      out = value();
    } else if (a == "--max-influences") {
      k = parse_int(a, value(), 1, 64);
    } else if (a == "--min-weight") {
      min_weight = parse_double(a, value(), 0.0, 0.999);
    } else if (a == "--method") {
      method = value();
      if (method != "model" && method != "bone-heat")
        throw InvalidArgument("--method expects model or bone-heat, got '" + method + "'");
    } else if (a == "--alias") {
      add_alias(aliases, value());
    } else if (a == "--device") {
      device = value();
    } else if (a == "--threads") {
      threads = parse_int(a, value(), 1, 1024);
    } else if (!a.empty() && a[0] != '-' && positional.size() < 2) {
      positional.push_back(a);
    } else {
      throw InvalidArgument("unknown or extra argument '" + a + "'");
    }
  }
  const bool heat = method == "bone-heat";
  const std::size_t want = heat ? 1 : 2;
  if (positional.size() != want || out.empty()) {
    if (positional.size() > want) std::fprintf(stderr, "gat predict-weights: extra argument '%s'\n", positional.back().c_str());
    usage(stderr);
    return 2;
  }
  const std::string model_path = heat ? std::string() : positional[0];
  in = positional.back();
  GATCORE_CHECK(is_gltf_path(in), in, ": predict-weights reads glTF characters (.glb / .gltf)");
  GATCORE_CHECK(is_gltf_path(out), out, ": the output must be a .glb or .gltf file");
  const std::filesystem::path dir = std::filesystem::path(out).parent_path();
  GATCORE_CHECK(dir.empty() || std::filesystem::is_directory(dir), out, ": the directory ", dir.string(),
                " does not exist");
  if (threads > 0) omp_set_num_threads(int(threads));
  if (heat) {
    GATCORE_CHECK(aliases.pairs.empty(), "--alias has no effect with --method bone-heat (no model bones to match)");
    const Character ch = load_gltf(in);
    BoneHeatParams bp;
    bp.max_influences = int(k);
    bp.min_weight = min_weight < 0 ? 0.01f : float(min_weight);
    const auto t0 = std::chrono::steady_clock::now();
    const SkinWeights w = bone_heat_weights(ch, bp);
    const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    save_gltf_with_weights(in, ch, w, out, int(k));
    std::printf("gat predict-weights: bone heat on %s: %lld vertices welded (%lld in the file), %d joints\n",
                in.c_str(), static_cast<long long>(ch.mesh.num_vertices()),
                static_cast<long long>(ch.num_file_vertices()), ch.skeleton.num_joints());
    std::printf("  influences per vertex: mean %.2f, max %lld (limit %ld, min weight %.3g); %.1f ms -> %s\n",
                double(w.joint.size()) / double(std::max<std::int64_t>(1, w.num_vertices())),
                static_cast<long long>(w.max_influences()), k, double(bp.min_weight), ms, out.c_str());
    return 0;
  }
  const Device dev = device_from_flag(device, "predict-weights");
  models::LoadedModel lm = models::load_checkpoint(model_path);
  if (lm.model->config().name == "skinweights-any") {
    // Skeleton-agnostic: each vertex's own nearest bones, no names to match.
    GATCORE_CHECK(aliases.pairs.empty(), "--alias has no effect with skinweights-any (it matches no bone names)");
    const Character ch = load_gltf(in);
    lm.model->to(dev);
    lm.model->fold_batch_norm();
    WeightPrediction p = predict_skin_weights_any(*lm.model, lm.norm, ch, int(k));
    if (min_weight > 0) p.weights = limit_weights(p.weights, int(k), float(min_weight));
    save_gltf_with_weights(in, ch, p.weights, out, int(k));
    std::printf("gat predict-weights: skinweights-any (%s, %lld candidate bones per vertex) on %s, device %s\n",
                model_path.c_str(), static_cast<long long>(lm.model->config().out_dim), in.c_str(),
                device_label(dev).c_str());
    std::printf("  %lld vertices welded (%lld in the file), %d joints\n", static_cast<long long>(ch.mesh.num_vertices()),
                static_cast<long long>(ch.num_file_vertices()), ch.skeleton.num_joints());
    std::printf("  influences per vertex: mean %.2f, max %lld (limit %ld)\n",
                double(p.weights.joint.size()) / double(std::max<std::int64_t>(1, p.weights.num_vertices())),
                static_cast<long long>(p.weights.max_influences()), k);
    std::printf("  features %.1f ms, inference %.1f ms -> %s\n", 1e3 * p.seconds_features, 1e3 * p.seconds_inference,
                out.c_str());
    return 0;
  }
  const std::vector<std::string> bones = character_model_bones(lm, model_path, models::Task::weights);
  const Character ch = load_gltf(in);
  lm.model->to(dev);
  lm.model->fold_batch_norm();
  WeightPrediction p = predict_skin_weights(*lm.model, lm.norm, bones, ch, int(k), aliases);
  if (min_weight > 0) p.weights = limit_weights(p.weights, int(k), float(min_weight));
  save_gltf_with_weights(in, ch, p.weights, out, int(k));

  std::printf("gat predict-weights: %s (%s, %zu bones) on %s, device %s\n", lm.model->config().name.c_str(),
              model_path.c_str(), bones.size(), in.c_str(), device_label(dev).c_str());
  std::printf("  %lld vertices welded (%lld in the file), %d joints: %d matched to the model's bones",
              static_cast<long long>(ch.mesh.num_vertices()), static_cast<long long>(ch.num_file_vertices()),
              ch.skeleton.num_joints(), p.mapping.num_mapped());
  if (!p.mapping.unmapped.empty()) {
    std::string names;
    for (std::size_t j = 0; j < p.mapping.unmapped.size() && j < 8; ++j) names += (j ? ", " : "") + p.mapping.unmapped[j];
    std::printf(", %zu without a bone get no weight (%s%s)", p.mapping.unmapped.size(), names.c_str(),
                p.mapping.unmapped.size() > 8 ? ", ..." : "");
  }
  std::printf("\n  influences per vertex: mean %.2f, max %lld (limit %ld)\n",
              double(p.weights.joint.size()) / double(std::max<std::int64_t>(1, p.weights.num_vertices())),
              static_cast<long long>(p.weights.max_influences()), k);
  std::printf("  features %.1f ms, inference %.1f ms -> %s\n", 1e3 * p.seconds_features, 1e3 * p.seconds_inference,
              out.c_str());
  return 0;
}

}  // namespace gat
