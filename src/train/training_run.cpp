#include "gatcore/train/training_run.hpp"

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "gatcore/error.hpp"
#include "gatcore/models/model_kind.hpp"
#include "gatcore/models/train.hpp"

namespace gatcore::train {

using models::ModelConfig;
using models::Task;

namespace {
std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
}  // namespace

std::string check_request(const RunRequest& r) {
  if (!r.init.empty() && r.data.empty()) return "--init " + r.init + " fine-tunes on a dataset: give --data";
  if (!r.init.empty() && !r.architecture_flags.empty())
    return "--init " + r.init + ": the model, its task, loss, linear skip and columns come from the checkpoint (drop " +
           r.architecture_flags.front() + ")";
  return "";
}

RunSettings resumed_settings(const models::CheckpointFile& f, const std::string& path, RunSettings asked) {
  const auto& md = f.metadata;
  const auto number = [&](const char* key) {
    const std::string& v = md.at(key);
    std::size_t end = 0;
    long x = 0;
    try {
      x = std::stol(v, &end);
    } catch (const std::exception&) {
      end = 0;
    }
    GATCORE_CHECK(end == v.size() && !v.empty(), path, ": metadata ", key, ": not an integer '", v, "'");
    return x;
  };
  // The run's data and batching come from the checkpoint, so the resumed
  // run continues exactly where the interrupted one stopped.
  if (md.count("seed") && md.count("samples") && md.count("batch")) {
    asked.seed = number("seed");
    asked.samples = number("samples");
    asked.batch = number("batch");
    if (md.count("sample_vertices")) asked.sample_vertices = number("sample_vertices");
    if (md.count("sampling")) asked.sampling = md.at("sampling");
  }
  // It keeps the precision asked for (a bad value in the file is refused
  // here, naming the checkpoint and the key).
  for (const char* key : {"precision_requested", "precision"})
    if (asked.precision.empty() && md.count(key)) {
      parse_precision(md.at(key), (path + ": metadata " + key).c_str());
      asked.precision = md.at(key);
    }
  if (asked.lr_schedule.empty() && md.count("lr_schedule")) {
    models::schedule_from_name(md.at("lr_schedule"), (path + ": metadata lr_schedule").c_str());
    asked.lr_schedule = md.at("lr_schedule");
  }
  if (asked.average_decay < 0 && md.count("average_decay"))
    asked.average_decay = models::metadata_number(md, "average_decay", 0.0, 0.999999, path);
  return asked;
}

std::string check_resumed_data(const std::string& resume, const std::string& checkpoint_data_path,
                               const std::string& data) {
  if (checkpoint_data_path.empty() && !data.empty())
    return resume + " was trained on the embedded tube data, not a dataset; drop --data";
  return "";
}

std::string check_new_model_options(const ModelConfig& cfg, const RunRequest& r) {
  const models::ModelKind kind = cfg.kind();
  if (r.nearest_joint_columns && cfg.task != Task::displacement)
    return "--joint-columns applies to displacement models; " + cfg.name +
           " learns skin weights (skinweights-any is the skin-weight model for any skeleton)";
  if (models::any_skeleton(kind)) {  // its columns are each vertex's own nearest bones, not the super skeleton
    if (r.data.empty()) return "skinweights-any learns from a dataset's characters (--data)";
  } else if (!r.pair_scorer.empty()) {
    return "--pair-scorer applies to skinweights-any, not " + cfg.name;
  }
  if (r.classifier_dropout >= 0 && !models::has_neuroskinning_classifier(kind))
    return "--classifier-dropout applies to the NeuroSkinning family (neuroskinning, neuroskinning-nopool, "
           "skinweights-any), not " + cfg.name;
  if (!r.loss.empty() && cfg.task == Task::weights && r.loss != "kl" && r.loss != "l1")
    return "--loss " + r.loss + ": " + cfg.name + " learns skin weights, whose loss is kl or l1";
  if (!r.loss.empty() && cfg.task == Task::displacement && r.loss != "mse" && r.loss != "l1")
    return "--loss " + r.loss + ": " + cfg.name + " learns displacements, whose loss is mse or l1";
  if (r.linear_skip && (!models::predicts_displacement(kind) || cfg.task != Task::displacement))
    return "--linear-skip applies to displacement models (the densegats family, origat), not " + cfg.name;
  return "";
}

void apply_architecture_options(ModelConfig& cfg, const RunRequest& r) {
  if (models::any_skeleton(cfg.kind())) cfg.pair_scorer = r.pair_scorer;
  if (r.classifier_dropout >= 0) cfg.classifier_dropout = r.classifier_dropout;
  if (!r.loss.empty() && cfg.task == Task::weights)
    cfg.weight_loss = r.loss == "l1" ? models::WeightLoss::l1 : models::WeightLoss::kl;
  else if (!r.loss.empty())
    cfg.loss = r.loss == "l1" ? models::DisplacementLoss::l1 : models::DisplacementLoss::mse;
  if (r.linear_skip) cfg.linear_skip = true;
}

std::string check_checkpoint_architecture(const ModelConfig& cfg, const RunRequest& r) {
  if (r.linear_skip && !cfg.linear_skip)
    return r.resume + " was trained without --linear-skip; a resumed run keeps its architecture";
  const std::string loss = models::loss_name(cfg);
  if (!r.resume.empty() && !r.loss.empty() && r.loss != loss)
    return r.resume + " was trained with the " + loss + " loss; a resumed run keeps it (drop --loss " + r.loss + ")";
  if (!r.resume.empty() && !r.pair_scorer.empty() && r.pair_scorer != cfg.pair_scorer)
    return r.resume + " has " + (cfg.pair_scorer.empty() ? "no pair scorer" : "another pair scorer") +
           "; a resumed run keeps its architecture (drop --pair-scorer)";
  if (!r.resume.empty() && r.classifier_dropout >= 0 && r.classifier_dropout != cfg.classifier_dropout)
    return r.resume + " was trained with classifier dropout " + number_text(cfg.classifier_dropout) +
           "; a resumed run keeps it (drop --classifier-dropout)";
  return "";
}

std::string keep_best_figure(const ModelConfig& cfg, const RunRequest& r, std::string* refusal) {
  const std::string by = r.keep_best_by.empty() ? (cfg.task == Task::weights ? "l1" : "loss") : r.keep_best_by;
  if (by == "l1" && cfg.task != Task::weights && refusal)
    *refusal = "--keep-best-by l1 needs a skin-weight model; " + cfg.name + " predicts displacements";
  return by;
}

std::string check_world_columns(const ModelConfig& cfg, const RunRequest& r, bool from_checkpoint,
                                bool checkpoint_ignores) {
  if (models::any_skeleton(cfg.kind())) {
    if (from_checkpoint && !r.world_columns.empty() && (r.world_columns == "ignore") != checkpoint_ignores)
      return "--world-columns " + r.world_columns + ": " + (r.init.empty() ? r.resume : r.init) + " " +
             (checkpoint_ignores ? "ignores" : "uses") + " them; a resumed or fine-tuned model keeps its own";
    return "";
  }
  if (!r.world_columns.empty()) return "--world-columns applies to skinweights-any, not " + cfg.name;
  return "";
}

void record_init(RunRecord& rec, const std::string& init, const models::CheckpointFile* init_file,
                 const models::CheckpointFile* resumed) {
  if (!init.empty()) {  // where a fine-tuned model started (a resumed fine-tune keeps it)
    rec.init_path = std::filesystem::absolute(init).string();
    if (init_file && init_file->metadata.count("epoch")) rec.init_epoch = init_file->metadata.at("epoch");
  } else if (resumed) {
    if (resumed->metadata.count("init")) rec.init_path = resumed->metadata.at("init");
    if (resumed->metadata.count("init_epoch")) rec.init_epoch = resumed->metadata.at("init_epoch");
  }
}

std::map<std::string, std::string> training_run_metadata(const RunRecord& rec) {
  std::map<std::string, std::string> md{{"seed", std::to_string(rec.seed)},
                                        {"samples", std::to_string(rec.samples)},
                                        {"batch", std::to_string(rec.batch)},
                                        {"sample_vertices", std::to_string(rec.sample_vertices)},
                                        {"sampling", models::sampling_name(rec.sampling)},
                                        {"precision", precision_name(rec.precision)},
                                        {"lr_schedule", models::schedule_name(rec.schedule)}};
  if (rec.precision != rec.precision_requested) md["precision_requested"] = precision_name(rec.precision_requested);
  if (!rec.init_path.empty()) md["init"] = rec.init_path;
  if (!rec.init_epoch.empty()) md["init_epoch"] = rec.init_epoch;
  if (!rec.loss_history.empty()) md["loss_history"] = rec.loss_history;
  return md;
}

RunRecord read_run_record(const models::CheckpointFile& f, const std::string& path) {
  const auto& md = f.metadata;
  const auto value = [&](const char* key) {
    const auto it = md.find(key);
    return it == md.end() ? std::string() : it->second;
  };
  const auto what = [&](const char* key) { return path + ": metadata " + key; };
  constexpr std::int64_t kMax = std::numeric_limits<std::int32_t>::max();
  RunRecord rec;
  if (md.count("seed")) rec.seed = long(models::metadata_integer(md, "seed", 0, kMax, path));
  if (md.count("samples")) rec.samples = long(models::metadata_integer(md, "samples", 0, kMax, path));
  if (md.count("batch")) rec.batch = int(models::metadata_integer(md, "batch", 0, kMax, path));
  if (md.count("sample_vertices"))
    rec.sample_vertices = models::metadata_integer(md, "sample_vertices", 0, std::int64_t(1) << 52, path);
  if (md.count("sampling")) {
    try {
      rec.sampling = models::sampling_from_name(md.at("sampling"));
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(what("sampling") + ": " + e.what());
    }
  }
  if (md.count("lr_schedule")) rec.schedule = models::schedule_from_name(md.at("lr_schedule"), what("lr_schedule").c_str());
  if (md.count("precision")) rec.precision = parse_precision(md.at("precision"), what("precision").c_str());
  rec.precision_requested = md.count("precision_requested")
                                ? parse_precision(md.at("precision_requested"), what("precision_requested").c_str())
                                : rec.precision;
  rec.init_path = value("init");
  rec.init_epoch = value("init_epoch");
  rec.loss_history = value("loss_history");
  return rec;
}

std::map<std::string, std::string> distillation_metadata(long seed, const std::string& teacher_path, double hard) {
  return {{"seed", std::to_string(seed)},
          {"distilled_from", std::filesystem::absolute(teacher_path).string()},
          {"distill_hard", std::to_string(hard)}};
}

}  // namespace gatcore::train
