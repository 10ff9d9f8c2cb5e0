// `gat eval`: loads a checkpoint and reports its loss and errors on held-out
// samples: the test characters of a dataset (--data, or the dataset the
// checkpoint was trained on) or the embedded tube data.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "gatcore/character/data/tube_data.hpp"
#include "commands.hpp"
#include "progress.hpp"
#include "eval_motion.hpp"
#include "eval_weight_baseline.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/dist/communicator.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/vulkan.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace {

struct EvalArgs {
  std::vector<std::string> models;
  std::string data, part = "test", json_path, errormap_dir, baseline;
  long samples = 16, seed = 12345, poses = 16, size = 320;
  double min_weight = 0;
  double heat_blend = 0;
  bool min_weight_given = false, heat_blend_given = false;
  long confusions = 0;
  gat::EvalMotionArgs motion;
  gat::CommonOptions common;
};

int run_eval(const EvalArgs& a);

}  // namespace

gat::Runner gat::setup_eval(CLI::App& gat) {
  auto a = std::make_shared<EvalArgs>();
  CLI::App& c = add_command(gat, "eval", "evaluate a checkpoint");
  set_details(c, 
      "Evaluates a checkpoint written by gat train on N held-out samples of the embedded tube data (not the training "
      "seeds) or of a dataset's characters: loss, and per-vertex error (displacements, in mesh units) or L1 weight "
      "error / bone precision and recall (skin weights, top-k post-processed). Skin-weight models on a dataset also "
      "print a per-character Markdown table (NeuroSkinning's metrics: bone precision / recall at 1e-4, L1 weight "
      "error, deformation error at the two worst random poses / height).\n"
      "With --motion: displacement models (LBS + predicted offsets) and the LBS and DQS baselines against the "
      "dataset's reference deformer (Delta Mush on LBS) on every K-th frame of each motion retargeted onto each "
      "character of the part: per-vertex distance mean / max / min per character and motion, per character, "
      "overall.");
  add_repeatable(c, "--model", a->models, "the checkpoint; with --motion: [LABEL=]FILE (each model gets a column)");
  c.add_option("--baseline", a->baseline,
               "the skin-weight table for a classical method instead of a model (needs --data): bone-heat, Baran & "
               "Popovic's heat diffusion (Blender's automatic weights), top 4 influences")
      ->check(one_of({"bone-heat"}));
  c.add_option("--min-weight", a->min_weight,
               "skin weights: drop predicted influences below W of the vertex's total (renormalised) before the "
               "metrics (default: a skinweights-any checkpoint's calibrated value (gat calibrate), else 0; bone "
               "heat: 0.01)")
      ->check(number_in(0, 0.999999));
  c.add_option("--heat-blend", a->heat_blend,
               "skinweights-any: mix the model's weights with bone heat's, (1 - S) * model + S * bone heat per vertex, "
               "top k kept (as gat predict-weights --heat-blend; default: the checkpoint's calibrated share (gat "
               "calibrate), else 0, the model alone)")
      ->check(number_in(0, 1));
  c.add_option("--confusions", a->confusions,
               "skin weights: after the table, each character's N largest dominant-bone confusions (artist's joint -> "
               "predicted joint: vertices), also in the JSON; shows which boundaries a method places differently")
      ->check(CLI::Range(0L, 1000L));
  c.add_option("--data", a->data,
               "evaluate on a dataset's characters (default: the dataset the checkpoint was trained on, if any; "
               "required with --motion); displacement: N poses per character");
  c.add_option("--part", a->part, "which characters of the dataset")
      ->check(one_of({"test", "validation", "train"}))->capture_default_str();
  c.add_option("--json", a->json_path, "also write the table as JSON");
  c.add_option("--errormaps", a->errormap_dir,
               "per-vertex error colour maps into DIR (skin weights: L1 weight error, DIR/<character>.png; "
               "--motion: see below)");
  add_device(c, a->common);
  add_threads(c, a->common);
  add_quiet(c, a->common);
  const char* plain = "Without --motion";
  c.add_option("--samples", a->samples, "held-out samples (tube data) / poses per character (dataset)")
      ->check(int_in(1, 1000000))->capture_default_str()->group(plain);
  add_seed(c, a->seed, "tube samples and the random poses of the deformation error")->group(plain);
  c.add_option("--poses", a->poses, "random poses per character for the deformation error (the dataset's pose angle)")
      ->check(int_in(0, 100000))->capture_default_str()->group(plain);
  c.add_option("--size", a->size, "error-map size in pixels")->check(int_in(16, 8192))->capture_default_str()->group(plain);
  const char* mo = "With --motion";
  auto& m = a->motion;
  add_repeatable(c, "--motion", m.motions, "a motion (.bvh, .amc, SKELETON.asf:MOTION.amc, other.glb#CLIP) to evaluate displacement models on")->group(mo);
  c.add_flag("--targets", m.targets,
             "evaluate on the frames of the characters' file targets (gat dataset build --target) instead; no "
             "--motion needed (characters with targets are always evaluated on them)")
      ->group(mo);
  c.add_flag("--linear-probe", m.linear_probe,
             "also evaluate the least-squares linear map of the models' input columns to the target, fitted on the "
             "training characters' epoch-0 poses (the linear probe a network has to beat; gat train --linear-skip "
             "starts there)")
      ->group(mo);
  c.add_option("--max-limit-excess", m.max_limit_excess_deg,
               "leave out frames whose pose leaves the dataset's random-pose joint limits (what training covered) "
               "by more than DEG degrees on some joint axis (counted as frames_excluded)")
      ->check(number_in(0, 360))->group(mo);
  c.add_option("--stride", m.stride, "every K-th frame")->check(int_in(1, 1000000))->capture_default_str()->group(mo);
  c.add_option("--markdown", m.markdown, "also write the tables as Markdown")->group(mo);
  c.add_option("--errormap-frames", m.errormap_frames,
               "frames of the first motion per character and method with error maps (one colour scale per frame: "
               "blue 0, red the 99th percentile of LBS's error in that frame, in the JSON, and above)")
      ->check(int_in(0, 1000))->capture_default_str()->group(mo);
  c.add_option("--errormap-size", m.errormap_size, "error-map size in pixels")
      ->check(int_in(32, 4096))->capture_default_str()->group(mo);
  add_repeatable(c, "--loss-curve", m.loss_curves,
               "LABEL=LOG: plots the train / validation loss per epoch of a `gat train` log (its 'epoch N/M  train "
               "loss X  val loss Y' lines) to DIR/loss_LABEL.png (repeatable; needs --errormaps DIR)")->group(mo);
  c.add_option("--cm-per-unit", m.cm_per_unit,
               "centimetres per world unit (default: 100 for glTF files, whose unit is the metre; unknown for other "
               "sources unless given)")
      ->check(positive_number())->group(mo);
  return [a, &c] {
    const bool motion = !a->motion.motions.empty() || a->motion.targets;
    // Each mode's options are refused in the other, naming them.
    for (const char* o : {"--samples", "--seed", "--poses", "--size", "--device"})
      GATCORE_CHECK(!motion || !c.count(o), o, " does not apply with --motion");
    for (const char* o : {"--stride", "--markdown", "--errormap-frames", "--errormap-size", "--loss-curve",
                          "--cm-per-unit", "--linear-probe", "--max-limit-excess"})
      GATCORE_CHECK(motion || !c.count(o), o, " applies only with --motion or --targets");
    for (const char* o : {"--baseline", "--min-weight", "--heat-blend"})
      GATCORE_CHECK(!motion || !c.count(o), o, " does not apply with --motion");
    apply_threads(a->common);
    a->min_weight_given = c.count("--min-weight") > 0, a->heat_blend_given = c.count("--heat-blend") > 0;
    if (motion) {
      EvalMotionArgs m = a->motion;
      m.models = a->models, m.data = a->data, m.part = a->part, m.json = a->json_path, m.errormaps = a->errormap_dir;
      m.quiet = a->common.quiet;
      return eval_motion(m);
    }
    if (!a->baseline.empty()) {
      GATCORE_CHECK(a->models.empty(), "--baseline evaluates a classical method; drop --model");
      GATCORE_CHECK(!c.count("--heat-blend"), "--heat-blend mixes a model's weights with bone heat's; it needs --model");
      GATCORE_CHECK(!a->data.empty(), "--baseline needs --data DATASET");
      return eval_weight_baseline(a->baseline, a->data, a->part, a->poses, a->seed,
                                  c.count("--min-weight") ? a->min_weight : -1.0, a->json_path, a->common.quiet,
                                  int(a->confusions));
    }
    GATCORE_CHECK(!a->models.empty(), "--model is required (or --baseline)");
    GATCORE_CHECK(a->models.size() == 1, "--model: give one checkpoint (got ", a->models.size(),
                  "); several are compared with --motion");
    return run_eval(*a);
  };
}

namespace {

int run_eval(const EvalArgs& a) {
  std::string path = a.models[0], data = a.data;
  const std::string part = a.part, json_path = a.json_path, errormap_dir = a.errormap_dir;
  const long samples = a.samples, seed = a.seed, poses = a.poses, size = a.size;
  const Device dev = gat::device_from_flag(a.common.device, "eval");
  gat::Activity doing("evaluating " + path);
  LoadedModel l = load_checkpoint(path);
  if (gatcore::models::any_skeleton(l.model->config().kind())) {
    // Each character's own joints (no super skeleton): the baselines' protocol.
    // The checkpoint's calibrated post-processing (gat calibrate) unless the flags say otherwise.
    const character::ModelDescription d = character::read_model_description(l.file, path);
    if (data.empty()) data = d.data_path;
    const character::WeightPostprocess pp = d.postprocess.value_or(character::WeightPostprocess{});
    const double min_weight = a.min_weight_given ? a.min_weight : double(pp.min_weight);
    const float heat_blend = a.heat_blend_given ? float(a.heat_blend) : pp.heat_blend;
    return gat::eval_weight_baseline(gatcore::models::model_kind_name(gatcore::models::ModelKind::skinweights_any),
                                     data, part, poses, seed, min_weight > 0 ? min_weight : -1.0, json_path,
                                     a.common.quiet, int(a.confusions), &l, heat_blend);
  }
  GATCORE_CHECK(a.heat_blend == 0, "--heat-blend: ", path, " is a ", l.model->config().name,
                " checkpoint; gat eval mixes bone heat only into skinweights-any's weights (each character's own "
                "joints; gat predict-weights --heat-blend works with every skin-weight model)");
  Model& m = *l.model;
  const ModelConfig& cfg = m.config();
  const character::ModelDescription described = character::read_model_description(l.file, path);
  if (data.empty()) data = described.data_path;
  std::vector<Sample> samples_;
  std::unique_ptr<character::TrainingData> td_;
  if (!data.empty()) {
    {
      gat::Progress loading("preparing the characters of " + data, 0, "characters", a.common.quiet);
      td_ = std::make_unique<character::TrainingData>(character::load_training_data(data, loading.callback()));
    }
    if (cfg.task == Task::displacement) td_->nearest_joints = character::checkpoint_nearest_joints(l.file, path);
    const character::TrainingData& td = *td_;
    if (!described.data_hash.empty() && described.data_hash != td.hash && described.data_path == data)
      std::fprintf(stderr, "gat eval: warning: %s has changed since %s was trained on it\n", data.c_str(), path.c_str());
    if (td.nearest_joints == 0 && !described.data_path.empty() && !described.skeleton.empty() &&
        described.skeleton != td.super.names) {
      std::fprintf(stderr, "gat eval: %s's super skeleton (%s) differs from the checkpoint's (%s)\n", data.c_str(),
                   character::joined_bone_names(td.super).c_str(),
                   character::joined_bone_names(described.skeleton).c_str());
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
    gat::Progress making("making " + part + " samples", 0, "samples", a.common.quiet);
    samples_ = character::training_samples(td, cfg.task, p, 0, k, int(samples), {}, making.callback());
    making.finish();
    if (samples_.empty()) {
      std::fprintf(stderr, "gat eval: %s has no %s characters\n", data.c_str(), part.c_str());
      return 2;
    }
  } else {
    GATCORE_CHECK(cfg.in_dim == character::kTubeFeatures, "model '", path, "' takes ", cfg.in_dim,
                  " features; the embedded tube data has ", character::kTubeFeatures);
    samples_ = character::tube_samples(cfg.task, int(samples), std::uint64_t(seed));
  }
  const auto& data_ = samples_;
  m.to(dev);
  m.fold_batch_norm();
  // Under mpirun / srun the samples are sharded over the ranks (sample i on
  // rank i mod N); every per-sample figure lands in its own slot, the slots
  // are summed over the ranks (exactly: one rank fills each) and rank 0
  // combines and prints them in sample order, the same numbers for any N.
  dist::Communicator& comm = dist::world();
  const bool root = comm.rank() == 0;
  const auto mine = [&](std::size_t i) { return int(i % std::size_t(comm.size())) == comm.rank(); };
  if (!root && !std::freopen("/dev/null", "w", stdout)) return 1;  // one report, from rank 0
  Trainer t(m, TrainOptions{}, l.norm, comm);
  const std::string device_label = dev == Device::vulkan ? vulkan::current_device().name : std::string("cpu");
  if (data.empty())
    std::printf("gat eval: %s (%s) from %s on %ld held-out tube samples, device %s\n", cfg.name.c_str(),
                task_name(cfg.task), path.c_str(), samples, device_label.c_str());
  else
    std::printf("gat eval: %s (%s) from %s on %zu samples of the %s characters of %s, device %s\n", cfg.name.c_str(),
                task_name(cfg.task), path.c_str(), data_.size(), part.c_str(), data.c_str(), device_label.c_str());
  const double loss = t.evaluate(data_);
  std::printf("  loss (%s, normalised targets): %.6f\n", loss_name(cfg), loss);
  // Per sample: error sum, max, LBS-alone sum, vertices, true / false positives, false negatives.
  constexpr std::size_t kStats = 7;
  std::vector<double> stats(data_.size() * kStats, 0.0);
  std::vector<Tensor> predictions(data_.size());
  gat::Progress pred_progress("predicting", std::int64_t(data_.size()), "samples", a.common.quiet || !root);
  for (std::size_t k = 0; k < data_.size(); ++k) {
    pred_progress.update(std::int64_t(k));
    if (!mine(k)) continue;
    const Sample& s = data_[k];
    Tensor y = predict(m, s, l.norm, cfg.task == Task::weights ? cfg.top_k : 0);
    if (cfg.task == Task::weights) predictions[k] = y;
    double err = 0, maxerr = 0, base = 0;
    std::int64_t count = 0, tp = 0, fp = 0, fn = 0;
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
    const double row[kStats] = {err, maxerr, base, double(count), double(tp), double(fp), double(fn)};
    std::copy(row, row + kStats, stats.begin() + std::ptrdiff_t(k * kStats));
  }
  pred_progress.finish();
  comm.sum(stats.data(), stats.size());
  double err = 0, maxerr = 0, base = 0;
  std::int64_t count = 0, tp = 0, fp = 0, fn = 0;
  for (std::size_t k = 0; k < data_.size(); ++k) {
    const double* r = stats.data() + k * kStats;
    err += r[0], maxerr = std::max(maxerr, r[1]), base += r[2];
    count += std::int64_t(r[3]), tp += std::int64_t(r[4]), fp += std::int64_t(r[5]), fn += std::int64_t(r[6]);
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
      eo.min_weight = float(a.min_weight);
      // The confusions are lists of names, not figures the ranks can sum.
      GATCORE_CHECK(a.confusions == 0 || comm.size() == 1,
                    "--confusions needs one process (drop it, or run gat eval without mpirun)");
      // Each character on the rank that predicted it; the figures gathered as above.
      constexpr std::size_t kFields = 11;
      std::vector<double> fields(data_.size() * kFields, 0.0);
      std::vector<character::CharacterWeightEval> per(data_.size());
      gat::Progress progress("evaluating " + part + " characters", std::int64_t(data_.size()), "characters",
                             a.common.quiet || !root);
      for (std::size_t i = 0; i < data_.size(); ++i) {
        progress.update(std::int64_t(i), std::filesystem::path(data_[i].name).stem().string());
        const std::int32_t c = chars[i];
        per[i].name = character::dataset_character_name(data_[i].name);
        if (!mine(i)) continue;
        const Tensor y = predictions[i].contiguous() ? predictions[i] : predictions[i].clone();
        const Tensor t = data_[i].target.contiguous() ? data_[i].target : data_[i].target.clone();
        const auto& mask = td.super.mask[std::size_t(c)];
        auto r = character::evaluate_character_weights(
            td.characters[std::size_t(c)], std::span<const float>(y.data(), std::size_t(y.numel())),
            std::span<const float>(t.data(), std::size_t(t.numel())), y.cols(), td.super.joint_to_bone[std::size_t(c)],
            mask, eo, c);
        r.name = per[i].name;
        per[i].confusions = std::move(r.confusions);  // names: one process only (checked above)
        if (!errormap_dir.empty()) {
          std::filesystem::create_directories(errormap_dir);
          const auto& mesh = td.characters[std::size_t(c)].character.mesh;
          character::RenderOptions ro;
          ro.width = ro.height = int(size);
          ro.max_error = 1.0f;  // L1 weight error in [0, 2]; one scale for every method
          ro.view_dir = {-0.55f, -0.25f, -0.8f};
          std::string file = r.name;
          for (char& ch : file)
            if (ch == '/' || ch == ':') ch = '_';
          const std::string png = (std::filesystem::path(errormap_dir) / (file + ".png")).string();
          character::write_png(png, character::render_error_map(mesh.positions, mesh.triangles, r.vertex_l1, ro));
        }
        const double f[kFields] = {double(r.vertices), r.height, r.weights.precision, r.weights.recall,
                                   r.weights.l1_mean, r.weights.l1_max, r.deformation.mean, r.deformation.max,
                                   r.deformation.min, double(r.deformation.count), r.dominant};
        std::copy(f, f + kFields, fields.begin() + std::ptrdiff_t(i * kFields));
      }
      progress.finish();
      comm.sum(fields.data(), fields.size());
      for (std::size_t i = 0; i < data_.size(); ++i) {
        const double* f = fields.data() + i * kFields;
        auto& r = per[i];
        r.vertices = std::int64_t(f[0]), r.height = f[1];
        r.weights = {f[2], f[3], f[4], f[5]};
        r.deformation.mean = f[6], r.deformation.max = f[7], r.deformation.min = f[8];
        r.deformation.count = std::int64_t(f[9]);
        r.dominant = f[10];
        if (!errormap_dir.empty()) {
          std::string file = r.name;
          for (char& ch : file)
            if (ch == '/' || ch == ':') ch = '_';
          std::printf("  error map: %s\n", (std::filesystem::path(errormap_dir) / (file + ".png")).string().c_str());
        }
      }
      gat::print_weight_table(per, eo, cfg.name, root ? json_path : std::string(), int(a.confusions));
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

}  // namespace
