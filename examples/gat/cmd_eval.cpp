// `gat eval`: loads a checkpoint and reports its loss and errors on held-out
// samples: the test characters of a dataset (--data, or the dataset the
// checkpoint was trained on) or the embedded tube data.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "commands.hpp"
#include "eval_motion.hpp"
#include "eval_weight_baseline.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/vulkan.hpp"
#include "tube_data.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

int usage(int rc) {
  std::fprintf(rc ? stderr : stdout,
               "usage: gat eval --model FILE [--samples N] [--seed S] [--data DATASET] [--part P]\n"
               "                [--device cpu|vulkan|auto] [--min-weight W]\n"
               "       gat eval --baseline bone-heat --data DATASET [--part P] [--poses K] [--min-weight W] [--json FILE]\n"
               "  Evaluates a checkpoint written by gat train on N held-out samples (default 16) of the\n"
               "  embedded tube data (seed S, default 12345; not the training seeds): loss, and per-vertex\n"
               "  error (displacements, in mesh units) or L1 weight error / bone precision and recall\n"
               "  (skin weights, top-k post-processed).\n"
               "  --data DATASET  evaluate on a dataset's characters instead (default: the dataset the\n"
               "                  checkpoint was trained on, if any); displacement: N poses per character\n"
               "  --part P        test (default), validation or train characters of the dataset\n"
               "  Skin-weight models on a dataset also print a per-character Markdown table (NeuroSkinning's\n"
               "  metrics: bone precision / recall at 1e-4, L1 weight error, deformation error at the two\n"
               "  worst random poses / height):\n"
               "  --poses K       random poses per character for the deformation error (default 16; the\n"
               "                  dataset's pose angle; pose seed = --seed)\n"
               "  --json FILE     also write the table as JSON\n"
               "  --min-weight W  drop predicted influences below W of the vertex's total (renormalised) before\n"
               "                  the metrics (default 0; bone heat: 0.01)\n"
               "  --baseline bone-heat  the same table for a classical method instead of a model: Baran &\n"
               "                  Popovic's bone heat (Blender's automatic weights), top 4 influences\n"
               "  --errormaps DIR per-vertex L1 weight-error colour maps, DIR/<character>.png\n"
               "  --size PX       error-map size (default 320)\n"
               "  --device D      cpu (default), vulkan or auto: where the model runs (see gat train --help)\n"
               "  --motion M.bvh  evaluate displacement models and the LBS / DQS baselines on every frame of\n"
               "                  retargeted motions instead (gat eval --motion X --help for its options)\n");
  return rc;
}

}  // namespace

int gat::cmd_eval(int argc, char** argv) {
  // Motion evaluation against the reference deformer, with baselines (eval_motion.cpp).
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--motion")) return gat::eval_motion(argc, argv);
  std::string path, data, part = "test", device = "cpu", json_path, errormap_dir, baseline;
  long samples = 16, seed = 12345, poses = 16, size = 320;
  double min_weight = -1;
  for (int i = 1; i < argc; ++i) {
    const bool v = i + 1 < argc;
    if (!std::strcmp(argv[i], "-h") || !std::strcmp(argv[i], "--help")) return usage(0);
    if (!std::strcmp(argv[i], "--model") && v) path = argv[++i];
    else if (!std::strcmp(argv[i], "--data") && v) data = argv[++i];
    else if (!std::strcmp(argv[i], "--part") && v) part = argv[++i];
    else if (!std::strcmp(argv[i], "--samples") && v) samples = std::strtol(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--seed") && v) seed = std::strtol(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--poses") && v) poses = std::strtol(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--size") && v) size = std::strtol(argv[++i], nullptr, 10);
    else if (!std::strcmp(argv[i], "--json") && v) json_path = argv[++i];
    else if (!std::strcmp(argv[i], "--errormaps") && v) errormap_dir = argv[++i];
    else if (!std::strcmp(argv[i], "--baseline") && v) baseline = argv[++i];
    else if (!std::strcmp(argv[i], "--min-weight") && v) {
      char* end = nullptr;
      min_weight = std::strtod(argv[++i], &end);
      if (*end || !(min_weight >= 0 && min_weight < 1)) {
        std::fprintf(stderr, "gat eval: --min-weight expects a number in [0, 1), got '%s'\n", argv[i]);
        return 2;
      }
    }
    else if (!std::strcmp(argv[i], "--device") && v) {
      device = argv[++i];
      if (device != "cpu" && device != "vulkan" && device != "auto") {
        std::fprintf(stderr, "gat eval: --device expects cpu, vulkan or auto, got '%s'\n", device.c_str());
        return 2;
      }
    }
    else {
      std::fprintf(stderr, "gat eval: unknown or incomplete option '%s'\n", argv[i]);
      return usage(2);
    }
  }
  if (!baseline.empty()) return gat::eval_weight_baseline(baseline, data, part, poses, seed, min_weight, json_path);
  if (path.empty()) {
    std::fprintf(stderr, "gat eval: --model FILE (or --baseline) is required\n");
    return usage(2);
  }
  if (samples < 1) {
    std::fprintf(stderr, "gat eval: --samples must be positive\n");
    return 2;
  }
  if (poses < 0 || poses > 100000 || size < 16 || size > 8192) {
    std::fprintf(stderr, "gat eval: --poses expects [0, 100000] (got %ld), --size [16, 8192] (got %ld)\n", poses, size);
    return 2;
  }
  const Device dev = device == "cpu" ? Device::cpu : vulkan::select(device == "auto" ? "auto" : "");
  LoadedModel l = load_checkpoint(path);
  if (l.model->config().name == "skinweights-any") {
    // Each character's own joints (no super skeleton): the baselines' protocol.
    if (data.empty() && l.file.metadata.count("data_path")) data = l.file.metadata.at("data_path");
    return gat::eval_weight_baseline("skinweights-any", data, part, poses, seed, min_weight, json_path, &l);
  }
  Model& m = *l.model;
  const ModelConfig& cfg = m.config();
  if (part != "test" && part != "validation" && part != "train") {
    std::fprintf(stderr, "gat eval: --part expects test, validation or train, got '%s'\n", part.c_str());
    return 2;
  }
  const auto& md = l.file.metadata;
  if (data.empty() && md.count("data_path")) data = md.at("data_path");
  std::vector<Sample> samples_;
  std::unique_ptr<character::TrainingData> td_;
  if (!data.empty()) {
    td_ = std::make_unique<character::TrainingData>(character::load_training_data(data));
    const character::TrainingData& td = *td_;
    if (md.count("data_hash") && md.at("data_hash") != td.hash && md.count("data_path") && md.at("data_path") == data)
      std::fprintf(stderr, "gat eval: warning: %s has changed since %s was trained on it\n", data.c_str(), path.c_str());
    const std::string bones = character::joined_bone_names(td.super);
    if (md.count("data_path") && md.count("skeleton") && md.at("skeleton") != bones) {
      std::fprintf(stderr, "gat eval: %s's super skeleton (%s) differs from the checkpoint's (%s)\n", data.c_str(),
                   bones.c_str(), md.at("skeleton").c_str());
      return 2;
    }
    GATCORE_CHECK(cfg.in_dim == td.feature_dim(cfg.task) &&
                      (cfg.task != Task::weights || cfg.out_dim == td.super.num_bones()),
                  "model '", path, "' takes ", cfg.in_dim, " features / ", cfg.out_dim, " outputs; dataset ", data,
                  " has ", td.feature_dim(cfg.task), " features over ", td.super.num_bones(), " bones");
    const auto p = part == "test" ? character::DatasetPart::test
                   : part == "validation" ? character::DatasetPart::validation : character::DatasetPart::train;
    int k = 1;
    for (int j : m.pool_sizes()) k = std::max(k, j);
    samples_ = character::training_samples(td, cfg.task, p, 0, k, int(samples));
    if (samples_.empty()) {
      std::fprintf(stderr, "gat eval: %s has no %s characters\n", data.c_str(), part.c_str());
      return 2;
    }
  } else {
    GATCORE_CHECK(cfg.in_dim == demo::kTubeFeatures, "model '", path, "' takes ", cfg.in_dim,
                  " features; the embedded tube data has ", demo::kTubeFeatures);
    samples_ = demo::tube_samples(cfg.task, int(samples), std::uint64_t(seed));
  }
  const auto& data_ = samples_;
  m.to(dev);
  m.fold_batch_norm();
  Trainer t(m, TrainOptions{}, l.norm);
  const std::string device_label = dev == Device::vulkan ? vulkan::current_device().name : std::string("cpu");
  if (data.empty())
    std::printf("gat eval: %s (%s) from %s on %ld held-out tube samples, device %s\n", cfg.name.c_str(),
                task_name(cfg.task), path.c_str(), samples, device_label.c_str());
  else
    std::printf("gat eval: %s (%s) from %s on %zu samples of the %s characters of %s, device %s\n", cfg.name.c_str(),
                task_name(cfg.task), path.c_str(), data_.size(), part.c_str(), data.c_str(), device_label.c_str());
  std::printf("  loss (%s, normalised targets): %.6f\n", cfg.task == Task::weights ? "KL" : "MSE", t.evaluate(data_));
  double err = 0, maxerr = 0, base = 0;
  std::int64_t count = 0, tp = 0, fp = 0, fn = 0;
  std::vector<Tensor> predictions;
  for (const Sample& s : data_) {
    Tensor y = predict(m, s, l.norm, cfg.task == Task::weights ? cfg.top_k : 0);
    if (cfg.task == Task::weights) predictions.push_back(y);
    for (std::int64_t i = 0; i < y.rows(); ++i, ++count) {
      double e = 0, b = 0;
      for (std::int64_t j = 0; j < y.cols(); ++j) {
        const double d = double(y.at(i, j)) - s.target.at(i, j);
        if (cfg.task == Task::weights) {
          e += std::abs(d);
          const bool p = y.at(i, j) > 1e-4f, g = s.target.at(i, j) > 0.f;
          tp += p && g, fp += p && !g, fn += !p && g;
        } else {
          e += d * d;
          b += double(s.target.at(i, j)) * s.target.at(i, j);
        }
      }
      if (cfg.task == Task::displacement) e = std::sqrt(e), b = std::sqrt(b);
      err += e, base += b, maxerr = std::max(maxerr, e);
    }
  }
  if (cfg.task == Task::weights) {
    std::printf("  L1 weight error per vertex: mean %.5f  max %.5f\n", err / double(count), maxerr);
    std::printf("  bone precision %.3f  recall %.3f\n", double(tp) / double(std::max<std::int64_t>(1, tp + fp)),
                double(tp) / double(std::max<std::int64_t>(1, tp + fn)));
    if (td_) {
      // NeuroSkinning's per-character evaluation (library: weight_eval.hpp).
      const auto& td = *td_;
      const auto& chars = td.part(part == "test" ? character::DatasetPart::test
                                  : part == "validation" ? character::DatasetPart::validation
                                                         : character::DatasetPart::train);
      character::WeightEvalOptions eo;
      eo.poses = int(poses);
      eo.pose_angle = td.description.pose_angle;
      eo.seed = std::uint32_t(seed);
      eo.min_weight = min_weight > 0 ? float(min_weight) : 0.0f;
      std::vector<character::CharacterWeightEval> per;
      for (std::size_t i = 0; i < data_.size(); ++i) {
        const std::int32_t c = chars[i];
        const Tensor y = predictions[i].contiguous() ? predictions[i] : predictions[i].clone();
        const Tensor t = data_[i].target.contiguous() ? data_[i].target : data_[i].target.clone();
        const auto& mask = td.super.mask[std::size_t(c)];
        auto r = character::evaluate_character_weights(
            td.characters[std::size_t(c)], std::span<const float>(y.data(), std::size_t(y.numel())),
            std::span<const float>(t.data(), std::size_t(t.numel())), y.cols(), td.super.joint_to_bone[std::size_t(c)],
            mask, eo, c);
        r.name = std::filesystem::path(data_[i].name).parent_path().filename().string() + "/" +
                 std::filesystem::path(data_[i].name).stem().string();
        if (!errormap_dir.empty()) {
          std::filesystem::create_directories(errormap_dir);
          const auto& mesh = td.characters[std::size_t(c)].character.mesh;
          character::RenderOptions ro;
          ro.width = ro.height = int(size);
          ro.max_error = 1.0f;  // L1 weight error in [0, 2]; one scale for every method
          ro.view_dir = {-0.55f, -0.25f, -0.8f};
          std::string file = r.name;
          std::replace(file.begin(), file.end(), '/', '_');
          const std::string png = (std::filesystem::path(errormap_dir) / (file + ".png")).string();
          character::write_png(png, character::render_error_map(mesh.positions, mesh.triangles, r.vertex_l1, ro));
          std::printf("  error map: %s\n", png.c_str());
        }
        per.push_back(std::move(r));
      }
      gat::print_weight_table(per, eo, cfg.name, json_path);
    } else if (!json_path.empty() || !errormap_dir.empty()) {
      std::fprintf(stderr, "gat eval: --json / --errormaps need a dataset (--data)\n");
      return 2;
    }
  } else {
    std::printf("  vertex error after correction: mean %.5f  max %.5f  (LBS alone: mean %.5f)\n", err / double(count),
                maxerr, base / double(count));
  }
  return 0;
}
