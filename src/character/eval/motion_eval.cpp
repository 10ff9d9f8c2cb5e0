// See eval_motion.hpp.
#include "gatcore/character/eval/motion_eval.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/models/linear_skip.hpp"

namespace gatcore::character {

using namespace gatcore::models;
namespace fs = std::filesystem;

namespace {

// Mean / max / min and a log-spaced histogram for percentiles: 4096 bins
// from 1e-8 to 1e2 units (each bin 0.56 % wide; errors outside land in the
// end bins), so the 99th percentile is exact to within half a percent
// without keeping millions of per-vertex errors per row.
struct Acc {
  static constexpr int kBins = 4096;
  static constexpr double kLo = -8.0, kHi = 2.0;  // log10 range
  double sum = 0, max = 0, min = std::numeric_limits<double>::infinity();
  std::int64_t count = 0;
  std::vector<std::int64_t> hist = std::vector<std::int64_t>(kBins, 0);
  void add(double e) {
    sum += e, ++count;
    max = std::max(max, e), min = std::min(min, e);
    const double b = e > 0 ? (std::log10(e) - kLo) / (kHi - kLo) * kBins : 0.0;
    ++hist[std::size_t(std::clamp(b, 0.0, double(kBins - 1)))];
  }
  void add(const Acc& o) {
    sum += o.sum, count += o.count;
    max = std::max(max, o.max), min = std::min(min, o.min);
    for (int b = 0; b < kBins; ++b) hist[std::size_t(b)] += o.hist[std::size_t(b)];
  }
  double mean() const { return count ? sum / double(count) : 0.0; }
  // The q-quantile (0..1) of what add() was given (the histogram is not
  // rescaled when sum / max / min are converted to cm): its bin's geometric middle.
  double quantile(double q) const {
    if (!count) return 0.0;
    const auto want = std::max<std::int64_t>(1, std::int64_t(std::ceil(q * double(count))));
    std::int64_t seen = 0;
    for (int b = 0; b < kBins; ++b) {
      seen += hist[std::size_t(b)];
      if (seen >= want) return std::pow(10.0, kLo + (b + 0.5) * (kHi - kLo) / kBins);
    }
    return std::pow(10.0, kHi);
  }
};

std::string stem(const std::string& p) { return fs::path(p).stem().string(); }

// "Casual.glb" of "modular_men": "men/Casual".
std::string character_label(const std::string& entry) {
  const fs::path p(entry);
  std::string dir = p.parent_path().filename().string();
  if (dir.rfind("modular_", 0) == 0) dir = dir.substr(8);
  return dir.empty() ? p.stem().string() : dir + "/" + p.stem().string();
}

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4f", v);
  return b;
}

}  // namespace

MotionEvalReport evaluate_motions(const MotionEvalOptions& o, const MotionEvalHooks& hooks) {
  const std::string& data = o.data;
  const std::string& part = o.part;
  const std::string& map_dir = o.errormaps;
  const std::vector<Motion>& motions = o.motions;
  const bool linear_probe = o.linear_probe;
  const double max_excess_deg = o.max_limit_excess_deg;  // < 0: every frame
  const long stride = o.stride, map_frames = o.errormap_frames, map_size = o.errormap_size;
  const double cm_per_unit = o.cm_per_unit;
  const auto log = [&](const std::string& line) {
    if (hooks.log) hooks.log(line);
  };
  const auto line = [](const char* format, auto... args) {
    char b[512];
    std::snprintf(b, sizeof b, format, args...);
    return std::string(b);
  };
  GATCORE_CHECK(!data.empty(), "--motion / --targets need --data DATASET");
  const auto t0 = std::chrono::steady_clock::now();
  TrainingData td = load_training_data(data, hooks.loading);  // nearest_joints set per probe below
  const std::string bones = joined_bone_names(td.super);
  struct M {
    std::string label, file;
    LoadedModel l;
    int nearest = 0;  // its joint columns (checkpoint_nearest_joints)
  };
  std::vector<M> models_;
  for (const auto& [label, file] : o.models) {
    M m{label, file, load_checkpoint(file)};
    const ModelConfig& cfg = m.l.model->config();
    GATCORE_CHECK(cfg.task == Task::displacement, file, ": model '", cfg.name,
                  "' predicts skin weights; --motion evaluates displacement models");
    const ModelDescription described = read_model_description(m.l.file, file);
    m.nearest = described.nearest_joints;
    GATCORE_CHECK(cfg.in_dim == td.displacement_feature_dim(m.nearest), file, " takes ", cfg.in_dim,
                  " features; ", data, " has ", td.displacement_feature_dim(m.nearest), " (joint columns ",
                  format_joint_columns(m.nearest), ", distortion scales: ",
                  format_distortion_scales(td.description.distortion_scales), ")");
    // Nearest-joint models name no bones: any dataset's skeletons will do.
    if (m.nearest == 0 && !described.skeleton.empty() && described.skeleton != td.super.names)
      throw InvalidArgument(detail::cat(file, ": trained on a super skeleton (", joined_bone_names(described.skeleton),
                                        ") that differs from ", data, "'s (", bones, ")"));
    if (m.label.empty()) m.label = cfg.name;
    m.l.model->fold_batch_norm();
    models_.push_back(std::move(m));
  }
  const auto dpart = part == "test" ? DatasetPart::test : part == "validation" ? DatasetPart::validation : DatasetPart::train;
  const auto& chars = td.part(dpart);
  GATCORE_CHECK(!chars.empty(), data, " has no ", part, " characters");

  // A bone-column model on a character lacking bones all its training
  // characters had reads inputs it never saw (character_model.hpp): say so
  // beside the numbers it explains.
  for (const auto& m : models_) {
    if (m.nearest > 0) continue;
    const BonePresence presence = checkpoint_bone_presence(m.l.file, m.file, td.super.names.size());
    for (std::int32_t c : chars) {
      BoneMapping has;  // which of the super skeleton's bones this character has (joint indices unused)
      for (std::uint8_t x : td.super.mask[std::size_t(c)]) has.bone_to_joint.push_back(x ? 0 : -1);
      const std::string w = unseen_absent_bones_warning(
          character_label(td.description.characters[std::size_t(c)]), unseen_absent_bones(has, td.super.names, presence),
          presence);
      if (!w.empty() && hooks.warn)
        hooks.warn(w + " (model " + m.label + "; a model trained with --joint-columns nearest:K has no such columns).");
    }
  }

  std::vector<std::string> methods = {"LBS", "DQS"};
  for (const auto& m : models_) methods.push_back(m.label);
  // The linear probe: least squares on the training characters' epoch-0
  // samples, one per joint-column layout among the models (a model is
  // compared with the fit on its own inputs): "linear probe" on the paper's
  // bone columns, "linear probe (nearest:K)" on nearest-joint ones.
  struct Probe {
    int nearest = 0;
    LinearMap map;
    Normaliser norm;
  };
  std::vector<Probe> probes;
  if (linear_probe) {
    std::vector<int> layouts{0};
    for (const auto& m : models_)
      if (std::find(layouts.begin(), layouts.end(), m.nearest) == layouts.end()) layouts.push_back(m.nearest);
    for (int layout : layouts) {
      const auto tp = std::chrono::steady_clock::now();
      td.nearest_joints = layout;
      const std::vector<Sample> train = training_samples(td, Task::displacement, DatasetPart::train, 0);
      GATCORE_CHECK(!train.empty(), "--linear-probe: ", data, " has no training samples");
      Probe p{layout, {}, Normaliser::fit(train, true)};
      p.map = fit_linear_map(train, p.norm, td.feature_dim(Task::displacement), 3);
      const std::string label = layout > 0 ? "linear probe (" + format_joint_columns(layout) + ")" : "linear probe";
      log(line("  %s: %lld training vertices, normalised MSE %.5f (zero: %.5f), %.1f s", label.c_str(),
               static_cast<long long>(p.map.rows), p.map.mse_after, p.map.mse_before,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - tp).count()));
      methods.push_back(label);
      probes.push_back(std::move(p));
    }
    td.nearest_joints = 0;  // the evaluation's own samples: the bone columns (models re-column from raw)
  }
  const std::size_t K = methods.size();
  if (!map_dir.empty()) fs::create_directories(map_dir);

  nlohmann::json rows = nlohmann::json::array(), maps = nlohmann::json::array();
  std::vector<Acc> overall(K), overall_cm(K);
  bool all_cm = true;
  double common_cm = -1;  // the characters' cm per unit when they all share one (else 0)
  struct Row {
    std::string character, motion;
    std::int64_t frames = 0, vertices = 0;
    double cm = 0;
    std::vector<Acc> acc;
    std::int64_t excluded = 0;  // frames left out (--max-limit-excess)
  };
  std::vector<Row> table, per_char;
  std::int64_t total_frames = 0, done_frames = 0;
  for (const Motion& mo : motions)
    total_frames += std::int64_t((mo.clip.frames.size() + std::size_t(stride) - 1) / std::size_t(stride));
  const std::int64_t all_frames = total_frames * std::int64_t(chars.size());
  for (std::int32_t c : chars) {
    const PreparedCharacter& pc = td.characters[std::size_t(c)];
    const std::string& entry = td.description.characters[std::size_t(c)];
    std::string ext = fs::path(entry).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char x) { return char(std::tolower(x)); });
    const double cm = cm_per_unit > 0 ? cm_per_unit : (ext == ".glb" || ext == ".gltf") ? 100.0 : 0.0;
    const double to_world = 1.0 / double(pc.normalisation.scale);
    const std::int64_t n = pc.character.mesh.num_vertices();
    Row chrow{character_label(entry), "all", 0, n, cm, std::vector<Acc>(K)};
    // A character with file targets is evaluated on their frames (the poses
    // of the motion that drove them); the others on the --motion BVHs.
    const bool files = pc.reference && pc.reference->num_frames() > 0;
    std::vector<std::string> seq_names;
    if (files) {
      for (const FileTargetSource& t : td.description.targets)
        if (t.character == c) seq_names.push_back(t.file);
    } else {
      for (const Motion& m : motions) seq_names.push_back(m.name);
    }
    if (seq_names.empty()) {  // --targets without --motion: nothing to pose this one with
      if (hooks.warn)
        hooks.warn(character_label(entry) + " has no file targets and no --motion was given: not evaluated");
      continue;
    }
    all_cm = all_cm && cm > 0;
    common_cm = common_cm < 0 ? cm : (common_cm == cm ? cm : 0.0);
    // The rule for poses outside what training covered (--max-limit-excess):
    // frames whose joints leave the dataset's random-pose limits by more
    // than the given angle are left out (and counted).
    const std::vector<JointLimit> limits = td.description.joint_limits
                                               ? td.description.joint_limits->limits_for(pc.character.skeleton)
                                               : uniform_limits(pc.character.skeleton, td.description.pose_angle);
    for (std::size_t mi = 0; mi < seq_names.size(); ++mi) {
      RetargetOptions ro;
      ro.target_name = pc.character.name;
      const Clip clip = files ? Clip{seq_names[mi], 30.0f, pc.target_poses}
                              : retarget(motions[mi], pc.character.skeleton, mat4_identity(), ro);
      Row row{character_label(entry), seq_names[mi], 0, n, cm, std::vector<Acc>(K)};
      std::vector<std::size_t> frames;
      for (std::size_t f = 0; f < clip.frames.size(); f += std::size_t(stride)) frames.push_back(f);
      std::vector<std::size_t> map_at;
      if (!map_dir.empty() && mi == 0)
        for (long k = 0; k < map_frames && !frames.empty(); ++k)
          map_at.push_back(frames[std::size_t((2 * k + 1) * frames.size() / std::size_t(2 * map_frames))]);
      const auto tc = std::chrono::steady_clock::now();
      for (std::size_t f : frames) {
        if (hooks.progress) hooks.progress(done_frames++, all_frames, character_label(entry));
        const Pose& pose = clip.frames[f];
        if (max_excess_deg >= 0 &&
            pose_limit_excess(pc.character.skeleton, pc.rest, pose, limits, pc.normalisation.origin_joint).radians > max_excess_deg * std::numbers::pi / 180.0) {
          ++row.excluded;
          continue;
        }
        DenseGatsSample raw;
        const Sample s = densegats_full_sample(td, c, pose, &raw, files ? std::int32_t(f) : -1);
        // Reference (Delta Mush) and DQS in normalised units.
        const std::vector<Mat4> g = global_transforms(pc.character.skeleton, pose);
        std::vector<Mat4> S(g.size());
        for (std::size_t j = 0; j < g.size(); ++j) S[j] = mul(g[j], pc.character.skeleton.inverse_bind[j]);
        const std::vector<float> dqs = apply_normalisation(pc.normalisation, dual_quaternion_skinning(pc.character.mesh, S));
        std::vector<std::vector<float>> err(K, std::vector<float>(std::size_t(n)));
        std::vector<Tensor> preds;
        // The frame's input per joint-column layout, each made once (models
        // and probes of one layout share it; bone columns are `s` itself).
        std::map<int, Sample> by_layout;
        const auto input = [&](int nearest) -> const Sample& {
          if (nearest == 0) return s;
          auto [it, fresh] = by_layout.try_emplace(nearest, s);
          if (fresh) it->second.features = displacement_model_features(td, raw, nearest);
          return it->second;
        };
        for (auto& m : models_) preds.push_back(predict(*m.l.model, input(m.nearest), m.l.norm));
        for (const Probe& p : probes) preds.push_back(predict_linear(p.map, input(p.nearest), p.norm));
        // The target is in the root frame; the reference in the world's.
        // (Model errors are differences of two root-frame offsets: the same
        // length in either frame.)
        std::vector<float> ref_world(std::size_t(3 * n));
        for (std::int64_t v = 0; v < n; ++v) {
          const Vec3 o = root_offset_to_world(raw, {raw.target.at(v, 0), raw.target.at(v, 1), raw.target.at(v, 2)});
          for (int a = 0; a < 3; ++a) ref_world[std::size_t(3 * v + a)] = raw.lbs.at(v, a) + o[std::size_t(a)];
        }
        for (std::int64_t v = 0; v < n; ++v) {
          double e[2] = {0, 0};
          for (int a = 0; a < 3; ++a) {
            const double ref = ref_world[std::size_t(3 * v + a)];
            e[0] += double(raw.target.at(v, a)) * raw.target.at(v, a);
            e[1] += (dqs[std::size_t(3 * v + a)] - ref) * (dqs[std::size_t(3 * v + a)] - ref);
          }
          err[0][std::size_t(v)] = float(std::sqrt(e[0]) * to_world);
          err[1][std::size_t(v)] = float(std::sqrt(e[1]) * to_world);
          for (std::size_t k = 0; k < preds.size(); ++k) {
            double d = 0;
            for (int a = 0; a < 3; ++a) {
              const double x = double(preds[k].at(v, a)) - raw.target.at(v, a);
              d += x * x;
            }
            err[2 + k][std::size_t(v)] = float(std::sqrt(d) * to_world);
          }
        }
        for (std::size_t k = 0; k < K; ++k)
          for (float e : err[k]) row.acc[k].add(e);
        ++row.frames;
        if (std::find(map_at.begin(), map_at.end(), f) != map_at.end()) {
          std::vector<float> world(std::size_t(3 * n));
          for (std::int64_t v = 0; v < n; ++v)
            for (int a = 0; a < 3; ++a)
              world[std::size_t(3 * v + a)] = float(ref_world[std::size_t(3 * v + a)] * to_world);
          RenderOptions ro;
          ro.width = ro.height = int(map_size);
          // One colour scale for every method of this frame: the 99th
          // percentile of LBS's error (a few reference outliers would
          // otherwise turn everything blue); larger errors are clamped (red).
          std::vector<float> sorted = err[0];
          const std::size_t q = std::min(sorted.size() - 1, std::size_t(0.99 * double(sorted.size())));
          std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(q), sorted.end());
          ro.max_error = std::max(sorted[q], 1e-12f);
          for (std::size_t k = 0; k < K; ++k) {
            std::string name = row.character + "_" + stem(seq_names[mi]) + "_f" + std::to_string(f) + "_" + methods[k];
            std::replace(name.begin(), name.end(), '/', '_');
            write_png((fs::path(map_dir) / (name + ".png")).string(),
                      render_error_map(world, pc.character.mesh.triangles, err[k], ro));
            maps.push_back({{"file", name + ".png"}, {"character", row.character}, {"motion", seq_names[mi]},
                            {"frame", f}, {"method", methods[k]}, {"colour_scale_top", ro.max_error},
                            {"colour_scale_top_cm", cm > 0 ? ro.max_error * cm : 0.0}});
          }
        }
      }
      if (hooks.row) {
        std::string text = line("  %-16s %-10s %4lld frames x %6lld vertices (%lld outside the limits left out, %.1f s):",
                                row.character.c_str(), stem(row.motion).c_str(), static_cast<long long>(row.frames),
                                static_cast<long long>(n), static_cast<long long>(row.excluded),
                                std::chrono::duration<double>(std::chrono::steady_clock::now() - tc).count());
        for (std::size_t k = 0; k < K; ++k) text += line("  %s %.5f", methods[k].c_str(), row.acc[k].mean());
        hooks.row(text);
      }
      for (std::size_t k = 0; k < K; ++k) chrow.acc[k].add(row.acc[k]);
      chrow.frames += row.frames;
      chrow.excluded += row.excluded;
      table.push_back(row);
    }
    for (std::size_t k = 0; k < K; ++k) {
      overall[k].add(chrow.acc[k]);
      Acc a = chrow.acc[k];
      if (cm > 0) a.sum *= cm, a.max *= cm, a.min *= cm;
      overall_cm[k].add(a);
    }
    per_char.push_back(chrow);
  }
  GATCORE_CHECK(!per_char.empty(), data, ": none of its ", part,
                " characters has file targets (gat dataset build --target); give --motion BVH to evaluate on motions");
  // Report.
  auto stats_json = [&](const Acc& a, double cm) {
    if (a.count == 0) return nlohmann::json{{"vertex_frames", 0}};  // every frame left out
    nlohmann::json j = {{"mean", a.mean()}, {"p99", a.quantile(0.99)}, {"max", a.max}, {"min", a.min},
                        {"vertex_frames", a.count}};
    if (cm > 0)
      j["mean_cm"] = a.mean() * cm, j["p99_cm"] = a.quantile(0.99) * cm, j["max_cm"] = a.max * cm,
      j["min_cm"] = a.min * cm;
    return j;
  };
  nlohmann::json j;
  j["format"] = "gatcore-eval-motion";
  j["version"] = 1;
  j["dataset"] = fs::absolute(data).lexically_normal().string();
  j["dataset_hash"] = td.hash;
  j["part"] = part;
  j["stride"] = stride;
  j["max_limit_excess_deg"] = max_excess_deg;
  if (td.description.reference == ReferenceKind::arap)
    j["reference"] = {{"name", "arap"}, {"iterations", td.description.arap.iterations},
                      {"handle_weight", td.description.arap.handle_weight}};
  else
    j["reference"] = {{"name", "delta_mush"}, {"iterations", td.description.delta_mush.iterations},
                      {"step", td.description.delta_mush.step}};
  if (!td.description.targets.empty()) j["reference"]["file_targets"] = td.description.targets.size();
  j["motions"] = o.motion_paths;
  j["methods"] = methods;
  for (const auto& m : models_) {
    const auto& md = m.l.file.metadata;
    nlohmann::json mj = {{"file", m.file}, {"model", m.l.model->config().name},
                         {"parameters", m.l.model->registry().num_parameters()}};
    for (const char* key : {"epoch", "seed", "samples", "batch"})
      if (md.count(key)) mj[key] = md.at(key);
    j["models"][m.label] = mj;
  }
  for (const auto& group : {&table, &per_char})
    for (const Row& r : *group) {
      nlohmann::json rj = {{"character", r.character}, {"motion", r.motion}, {"frames", r.frames},
                           {"frames_excluded", r.excluded},
                           {"vertices", r.vertices}, {"cm_per_unit", r.cm}};
      for (std::size_t k = 0; k < K; ++k) rj["methods"][methods[k]] = stats_json(r.acc[k], r.cm);
      rows.push_back(rj);
    }
  j["rows"] = rows;
  j["errormaps"] = maps;
  for (std::size_t k = 0; k < K; ++k) {
    j["overall"][methods[k]] = stats_json(overall[k], 0);
    if (all_cm && overall[k].count > 0) {
      j["overall"][methods[k]]["mean_cm"] = overall_cm[k].mean();
      j["overall"][methods[k]]["max_cm"] = overall_cm[k].max;
      if (common_cm > 0) j["overall"][methods[k]]["p99_cm"] = overall[k].quantile(0.99) * common_cm;
      j["overall"][methods[k]]["min_cm"] = overall_cm[k].min;
    }
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  j["seconds"] = secs;

  std::ostringstream md;
  const char* u = all_cm ? "cm" : "units";
  md << "Overall (" << per_char.size() << " " << part << " characters, every " << stride
     << (stride == 1 ? "" : "th") << " frame of " << motions.size() << " motion(s) or file targets; per-vertex distance to the reference, "
     << u << "; p99: the 99th percentile, within 0.6 %):\n\n| method | mean | p99 | max | min |\n|---|---:|---:|---:|---:|\n";
  for (std::size_t k = 0; k < K; ++k) {
    const Acc& a = all_cm ? overall_cm[k] : overall[k];
    if (a.count == 0) {  // every frame left out (--max-limit-excess)
      md << "| " << methods[k] << " | - | - | - | - |\n";
      continue;
    }
    const double p99 = all_cm ? (common_cm > 0 ? overall[k].quantile(0.99) * common_cm : -1.0) : overall[k].quantile(0.99);
    md << "| " << methods[k] << " | " << fmt(a.mean()) << " | " << (p99 >= 0 ? fmt(p99) : std::string("-")) << " | "
       << fmt(a.max) << " | " << fmt(a.min) << " |\n";
  }
  if (max_excess_deg >= 0) {
    std::int64_t ex = 0, kept = 0;
    for (const Row& r : per_char) ex += r.excluded, kept += r.frames;
    md << "\nFrames whose pose leaves the dataset's random-pose joint limits by more than " << max_excess_deg
       << " degrees are left out: " << ex << " of " << ex + kept << ".\n";
  }
  md << "\nPer character and motion (mean / p99 / max / min, " << u << "):\n\n| character | motion | frames | vertices |";
  for (const auto& m : methods) md << " " << m << " |";
  md << "\n|---|---|---:|---:|";
  for (std::size_t k = 0; k < K; ++k) md << "---:|";
  md << "\n";
  for (const auto& group : {&table, &per_char})
    for (const Row& r : *group) {
      md << "| " << r.character << " | " << (r.motion == "all" ? "all" : stem(r.motion)) << " | " << r.frames << " | "
         << r.vertices << " |";
      const double s = all_cm ? r.cm : 1.0;
      for (std::size_t k = 0; k < K; ++k)
        if (r.acc[k].count == 0)  // every frame left out (--max-limit-excess)
          md << " - |";
        else
          md << " " << fmt(r.acc[k].mean() * s) << " / " << fmt(r.acc[k].quantile(0.99) * s) << " / "
             << fmt(r.acc[k].max * s) << " / " << fmt(r.acc[k].min * s) << " |";
      md << "\n";
    }
  MotionEvalReport report;
  report.methods = methods;
  report.characters = per_char.size();
  report.markdown = md.str();
  report.json = j.dump(2) + "\n";
  report.seconds = secs;
  return report;
}

}  // namespace gatcore::character
