// `gat distill TEACHER.gcm [--model origat] [--out student.gcm] ...`: trains
// a compact displacement model to imitate a large one (models/distill.hpp)
// on the teacher's dataset: each epoch's training samples (the same random
// poses and vertex windows `gat train --data` uses) get the teacher's
// predictions as targets. The student checkpoint carries the teacher's
// bones, distortion scales and dataset, so `gat deform`, `gat eval` and the
// runtime (runtime.hpp, gatcore.h) use it like any trained checkpoint.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/distill.hpp"
#include "gatcore/models/linear_skip.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/train/training_run.hpp"
#include "progress.hpp"

using namespace gatcore;
using namespace gatcore::models;

namespace gat {

namespace {

struct DistillArgs {
  std::string teacher_path, student_name = "origat", out = "student.gcm", data;
  long epochs = 10, seed = 0, samples = 0;
  double minutes = 0, hard = 0, lr = 1e-3;
  bool linear_skip = false;
  CommonOptions common;
};

int run_distill(const DistillArgs& a) {
  const std::string teacher_path = a.teacher_path, student_name = a.student_name, out = a.out;
  std::string data = a.data;
  const long epochs = a.epochs, seed = a.seed, samples = a.samples;
  const double minutes = a.minutes, hard = a.hard, lr = a.lr;
  apply_threads(a.common);
  const std::filesystem::path out_dir = std::filesystem::path(out).parent_path();
  GATCORE_CHECK(out_dir.empty() || std::filesystem::is_directory(out_dir), out, ": the directory ", out_dir.string(),
                " does not exist");

  LoadedModel teacher = load_checkpoint(teacher_path);
  const std::vector<std::string> bones =
      character::character_model_bones(teacher, teacher_path, Task::displacement);  // checks the kind
  // The student applies to characters as its teacher does: its features, bones and training set.
  character::ModelDescription description = character::read_model_description(teacher.file, teacher_path);
  if (data.empty()) {
    GATCORE_CHECK(!description.data_path.empty(), teacher_path, ": no data_path in the metadata; give --data");
    data = description.data_path;
  }
  const character::TrainingData td = [&] {
    Progress loading("preparing the characters of " + data, 0, "characters", a.common.quiet);
    character::TrainingData t = character::load_training_data(data, loading.callback());
    t.nearest_joints = description.nearest_joints;  // the student's too
    return t;
  }();
  GATCORE_CHECK(td.nearest_joints > 0 || td.super.names == description.skeleton, data,
                ": its super skeleton differs from the one ", teacher_path, " was trained on");
  GATCORE_CHECK(td.feature_dim(Task::displacement) == teacher.model->config().in_dim, data, ": ",
                td.feature_dim(Task::displacement), " features per vertex, ", teacher_path, " takes ",
                teacher.model->config().in_dim, " (different distortion scales?)");
  teacher.model->fold_batch_norm();  // inference only: the same predictions, less work

  ModelConfig cfg = ModelConfig::defaults(student_name, td.feature_dim(Task::displacement), 3);
  GATCORE_CHECK(cfg.task == Task::displacement, "--model ", student_name, " predicts skin weights; the student must ",
                "predict displacements (densegats, densegats-noself, densegats-nodense, origat)");
  cfg.loss = teacher.model->config().loss;
  cfg.linear_skip = a.linear_skip;
  auto student = make_model(cfg, std::uint64_t(seed));

  const bool quiet = a.common.quiet;
  const auto part = [&](character::DatasetPart p, int epoch) {
    const std::string which = p == character::DatasetPart::train ? "training" : "validation";
    std::vector<Sample> s;
    {
      Progress making("making " + which + " samples", 0, "samples", quiet);
      s = character::training_samples(td, Task::displacement, p, epoch, 1, int(samples), {}, making.callback());
    }
    Activity doing("computing the teacher's " + which + " targets");
    distill_targets(*teacher.model, teacher.norm, s, float(hard));
    return s;
  };
  std::vector<Sample> train = part(character::DatasetPart::train, 0);
  const std::vector<Sample> val = part(character::DatasetPart::validation, 0);
  GATCORE_CHECK(!train.empty(), data, ": no training samples");
  const Normaliser norm = Normaliser::fit(train, true);
  if (cfg.linear_skip) {
    // Fitted to the teacher's answers (the samples' targets by now), so the
    // student starts at the best linear imitation of its teacher.
    const LinearMap f = fit_linear_skip(*student, train, norm);
    if (!quiet)
      std::printf("linear skip: least-squares fit of the teacher on %lld training vertices, MSE %.6f (predicting "
                  "zero: %.6f)\n",
                  static_cast<long long>(f.rows), f.mse_after, f.mse_before);
  }
  TrainOptions opt = TrainOptions::defaults_for(cfg);
  opt.seed = std::uint64_t(seed);
  opt.lr = float(lr);
  Trainer trainer(*student, opt, norm);

  description.features = character::FeatureKind::densegats;
  description.data_path = std::filesystem::absolute(data).string();
  description.data_hash = td.hash;
  description.distortion_scales = td.description.distortion_scales;
  description.nearest_joints = td.nearest_joints;
  description.world_columns_ignored.reset();
  description.feature_layout.clear();
  std::map<std::string, std::string> extra = character::model_description_metadata(description);
  extra.merge(train::distillation_metadata(seed, teacher_path, hard));
  if (!quiet)
    std::printf("gat distill: %s (%lld parameters) imitating %s (%s, %lld parameters) on %s: %zu training / %zu "
              "validation samples, ground-truth weight %g, %d threads\n",
              cfg.name.c_str(), static_cast<long long>(student->registry().num_parameters()), teacher_path.c_str(),
              teacher.model->config().name.c_str(),
              static_cast<long long>(teacher.model->registry().num_parameters()), data.c_str(), train.size(),
              val.size(), hard, omp_get_max_threads());
  const auto t0 = std::chrono::steady_clock::now();
  // One progress line for the whole run: the batches of every epoch (rate
  // and time left over all of them), the epoch and its loss as the note.
  Progress progress("distilling", 0, "batches", quiet);
  const int first = trainer.epoch();
  while (trainer.epoch() < epochs) {
    if (trainer.epoch() > 0) train = part(character::DatasetPart::train, trainer.epoch());
    const EpochStats st = trainer.run_epoch(train, val, [&](int e, std::int64_t b, std::int64_t nb, double loss) {
      progress.set_total(nb * (epochs - first));
      char note[64];
      std::snprintf(note, sizeof note, "epoch %d/%ld  loss %.5f", e, epochs, loss);
      progress.update(std::int64_t(e - 1 - first) * nb + b, note);
    });
    progress.finish();  // the epoch's line below replaces it; the next batch redraws it
    save_checkpoint(out, *student, norm, &trainer, extra);
    if (!quiet)
      std::printf("epoch %d/%ld  train loss %.6f  val loss (vs teacher) %.6f  lr %.3g  (%.1f s)  -> %s\n", st.epoch,
                epochs, st.train_loss, st.val_loss, st.lr, st.seconds, out.c_str());
    std::fflush(stdout);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (minutes > 0 && s >= minutes * 60.0) {
      std::printf("time budget of %g minutes reached after epoch %d; student written to %s\n", minutes, st.epoch,
                  out.c_str());
      return 0;
    }
  }
  std::printf("distilled %ld epochs; student written to %s\n", epochs, out.c_str());
  return 0;
}

}  // namespace

Runner setup_distill(CLI::App& gat) {
  auto a = std::make_shared<DistillArgs>();
  CLI::App& c = add_command(gat, "distill",
                            "train a compact deploy model (e.g. origat) to imitate a large displacement model");
  set_details(c, "Trains a compact displacement model to imitate TEACHER (a densegats-family checkpoint trained with "
                 "gat train --data): its targets are the teacher's predictions on each training sample. The result "
                 "deforms like any checkpoint (gat deform, the runtime).");
  c.add_option("TEACHER", a->teacher_path, "the teacher checkpoint (.gcm)")->required();
  c.add_option("--model", a->student_name,
               "the student, with its paper defaults (any displacement model: densegats, densegats-noself, "
               "densegats-nodense, origat)")
      ->capture_default_str();
  add_out(c, a->out, "the student checkpoint, written after every epoch")->capture_default_str();
  c.add_option("--data", a->data, "the dataset (default: the one TEACHER was trained on, metadata data_path)");
  c.add_option("--epochs", a->epochs, "epochs")->check(int_in(1, 10000000))->capture_default_str();
  c.add_option("--minutes", a->minutes, "no new epoch after M minutes")->check(number_in(1e-6, 1e9));
  c.add_option("--hard", a->hard, "weight of the ground truth in the targets, in [0, 1] (0: teacher only)")
      ->check(number_in(0, 1))->capture_default_str();
  c.add_option("--samples", a->samples, "poses per character and epoch (default: all of the dataset's)")
      ->check(int_in(1, 1000000));
  c.add_flag("--linear-skip", a->linear_skip,
             "give the student a per-vertex linear map of its inputs added to its output, fitted by least squares "
             "to the teacher's predictions before the first epoch (the small network learns the rest; see gat "
             "train --linear-skip)");
  c.add_option("--lr", a->lr, "initial learning rate")->check(number_in(1e-12, 10))->capture_default_str();
  add_seed(c, a->seed, "the student's initialisation and the samples");
  add_threads(c, a->common);
  add_quiet(c, a->common);
  return [a] { return run_distill(*a); };
}

}  // namespace gat
