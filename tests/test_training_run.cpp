// The training-run rules (train/training_run.hpp): what a resumed run keeps,
// which options apply to which model, and the run's record in the checkpoint.
#include <catch2/catch.hpp>

#include "gatcore/error.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/train/training_run.hpp"

using namespace gatcore;
using namespace gatcore::train;
using models::ModelConfig;

namespace {

ModelConfig config(const char* name) { return ModelConfig::defaults(name, 8, 5); }

}  // namespace

TEST_CASE("training run: a fine-tune needs a dataset and takes the architecture from its checkpoint") {
  RunRequest r;
  CHECK(check_request(r).empty());
  r.init = "a.gcm";
  CHECK(check_request(r) == "--init a.gcm fine-tunes on a dataset: give --data");
  r.data = "d.json";
  CHECK(check_request(r).empty());
  r.architecture_flags = {"--loss", "--model"};
  CHECK(check_request(r) ==
        "--init a.gcm: the model, its task, loss, linear skip and columns come from the checkpoint (drop --loss)");
}

TEST_CASE("training run: a resume continues with the checkpoint's data, batching, precision and schedule") {
  models::CheckpointFile f;
  f.metadata = {{"seed", "7"},       {"samples", "12"},           {"batch", "3"},         {"sample_vertices", "100"},
                {"sampling", "full"}, {"precision", "fp32"},       {"precision_requested", "bf16"},
                {"lr_schedule", "cosine"}};
  RunSettings asked;
  asked.seed = 1, asked.samples = 64, asked.batch = 8;
  RunSettings s = resumed_settings(f, "m.gcm", asked);
  CHECK(s.seed == 7);
  CHECK(s.samples == 12);
  CHECK(s.batch == 3);
  CHECK(s.sample_vertices == 100);
  CHECK(s.sampling == "full");
  CHECK(s.precision == "bf16");  // what was asked for, not what the machine ran
  CHECK(s.lr_schedule == "cosine");
  // Asked-for precision and schedule win; a checkpoint without the run's numbers keeps the asked ones.
  asked.precision = "fp32";
  asked.lr_schedule = "step";
  f.metadata.erase("batch");
  s = resumed_settings(f, "m.gcm", asked);
  CHECK(s.seed == 1);
  CHECK(s.batch == 8);
  CHECK(s.precision == "fp32");
  CHECK(s.lr_schedule == "step");
  // Bad values are refused naming the file and the key.
  f.metadata["batch"] = "3x";
  CHECK_THROWS_WITH(resumed_settings(f, "m.gcm", {}), Catch::Contains("m.gcm") && Catch::Contains("batch"));
  f.metadata["batch"] = "3";
  f.metadata["lr_schedule"] = "linear";
  CHECK_THROWS_WITH(resumed_settings(f, "m.gcm", {}), Catch::Contains("m.gcm: metadata lr_schedule"));
  f.metadata["lr_schedule"] = "step";
  f.metadata["precision_requested"] = "fp64";
  CHECK_THROWS_WITH(resumed_settings(f, "m.gcm", {}), Catch::Contains("m.gcm: metadata precision_requested"));
}

TEST_CASE("training run: a tube model does not resume on a dataset") {
  CHECK(check_resumed_data("m.gcm", "", "d.json") == "m.gcm was trained on the embedded tube data, not a dataset; drop --data");
  CHECK(check_resumed_data("m.gcm", "", "").empty());
  CHECK(check_resumed_data("m.gcm", "/x/d.json", "other.json").empty());
}

TEST_CASE("training run: each option applies to the models it names") {
  RunRequest r;
  CHECK(check_new_model_options(config("densegats"), r).empty());
  r.nearest_joint_columns = true;
  CHECK_THAT(check_new_model_options(config("neuroskinning"), r), Catch::StartsWith("--joint-columns applies to displacement"));
  CHECK(check_new_model_options(config("densegats"), r).empty());
  r = {};
  CHECK(check_new_model_options(config("skinweights-any"), r) == "skinweights-any learns from a dataset's characters (--data)");
  r.data = "d.json";
  r.pair_scorer = {16};
  CHECK(check_new_model_options(config("skinweights-any"), r).empty());
  CHECK(check_new_model_options(config("neuroskinning"), r) == "--pair-scorer applies to skinweights-any, not neuroskinning");
  r = {};
  r.loss = "mse";
  CHECK(check_new_model_options(config("fc"), r) == "--loss mse: fc learns skin weights, whose loss is kl or l1");
  r.loss = "kl";
  CHECK(check_new_model_options(config("densegats"), r) ==
        "--loss kl: densegats learns displacements, whose loss is mse or l1");
  CHECK(check_new_model_options(config("skinweights-any"), RunRequest{.data = "d.json", .loss = "kl"}).empty());
  ModelConfig weights = config("skinweights-any");
  apply_architecture_options(weights, RunRequest{.data = "d.json", .loss = "kl"});
  CHECK(weights.weight_loss == models::WeightLoss::kl);
  CHECK(weights.loss == models::DisplacementLoss::mse);  // the displacement field stays as it was
  r = {};
  r.linear_skip = true;
  CHECK(check_new_model_options(config("origat"), r).empty());
  CHECK_THAT(check_new_model_options(config("pointnet"), r), Catch::StartsWith("--linear-skip applies"));
  ModelConfig ns_displacement = config("neuroskinning");
  ns_displacement.task = models::Task::displacement;  // --task displacement: still no linear skip
  CHECK_THAT(check_new_model_options(ns_displacement, r), Catch::StartsWith("--linear-skip applies"));

  ModelConfig c = config("densegats");
  r.loss = "l1";
  apply_architecture_options(c, r);
  CHECK(c.loss == models::DisplacementLoss::l1);
  CHECK(c.linear_skip);
  ModelConfig any = config("skinweights-any");
  r = {};
  r.pair_scorer = {16, 8};
  apply_architecture_options(any, r);
  CHECK(any.pair_scorer == std::vector<std::int64_t>{16, 8});
  CHECK(any.classifier_dropout == 0.5f);                            // not asked: the model's default
  CHECK(config("neuroskinning").classifier_dropout == 0.0f);        // the paper's network

  r = {};
  r.data = "d.json";
  r.classifier_dropout = 0.25f;
  for (const char* name : {"neuroskinning", "neuroskinning-nopool", "skinweights-any"})
    CHECK(check_new_model_options(config(name), r).empty());
  for (const char* name : {"densegats", "fc", "pointnet"})
    CHECK(check_new_model_options(config(name), r) ==
          std::string("--classifier-dropout applies to the NeuroSkinning family (neuroskinning, neuroskinning-nopool, "
                      "skinweights-any), not ") + name);
  apply_architecture_options(any, r);
  CHECK(any.classifier_dropout == 0.25f);
  r.classifier_dropout = 0.0f;  // asked for none: the model without dropout
  apply_architecture_options(any, r);
  CHECK(any.classifier_dropout == 0.0f);
}

TEST_CASE("training run: a checkpoint's model keeps its architecture") {
  ModelConfig c = config("densegats");
  c.loss = models::DisplacementLoss::l1;
  RunRequest r;
  r.resume = "m.gcm";
  CHECK(check_checkpoint_architecture(c, r).empty());
  r.linear_skip = true;
  CHECK(check_checkpoint_architecture(c, r) == "m.gcm was trained without --linear-skip; a resumed run keeps its architecture");
  r.linear_skip = false;
  r.loss = "mse";
  CHECK(check_checkpoint_architecture(c, r) == "m.gcm was trained with the l1 loss; a resumed run keeps it (drop --loss mse)");
  r.loss = "l1";
  CHECK(check_checkpoint_architecture(c, r).empty());
  r.pair_scorer = {8};
  CHECK(check_checkpoint_architecture(c, r) == "m.gcm has no pair scorer; a resumed run keeps its architecture (drop --pair-scorer)");

  ModelConfig any = config("skinweights-any");
  any.classifier_dropout = 0.5f;
  r = {};
  r.resume = "m.gcm";
  CHECK(check_checkpoint_architecture(any, r).empty());  // not asked: the checkpoint's
  r.classifier_dropout = 0.5f;
  CHECK(check_checkpoint_architecture(any, r).empty());
  r.classifier_dropout = 0.25f;
  CHECK(check_checkpoint_architecture(any, r) ==
        "m.gcm was trained with classifier dropout 0.5; a resumed run keeps it (drop --classifier-dropout)");
}

TEST_CASE("training run: --keep-best's figure and --world-columns") {
  RunRequest r;
  std::string why;
  CHECK(keep_best_figure(config("neuroskinning"), r, &why) == "l1");
  CHECK(keep_best_figure(config("densegats"), r, &why) == "loss");
  CHECK(why.empty());
  r.keep_best_by = "l1";
  keep_best_figure(config("densegats"), r, &why);
  CHECK(why == "--keep-best-by l1 needs a skin-weight model; densegats predicts displacements");

  r = {};
  r.world_columns = "use";
  CHECK(check_world_columns(config("neuroskinning"), r, false, false) ==
        "--world-columns applies to skinweights-any, not neuroskinning");
  CHECK(check_world_columns(config("skinweights-any"), r, false, false).empty());
  r.init = "a.gcm";
  CHECK(check_world_columns(config("skinweights-any"), r, true, true) ==
        "--world-columns use: a.gcm ignores them; a resumed or fine-tuned model keeps its own");
  CHECK(check_world_columns(config("skinweights-any"), r, true, false).empty());
}

namespace {

models::CheckpointFile file_of_record(const RunRecord& rec) {
  models::CheckpointFile f;
  f.metadata = training_run_metadata(rec);
  return f;
}

}  // namespace

TEST_CASE("training run: the record in the checkpoint") {
  RunRecord rec;
  rec.seed = 3, rec.samples = 16, rec.batch = 2, rec.sample_vertices = 2048;
  rec.sampling = models::Sampling::random;
  rec.schedule = models::Schedule::cosine;
  rec.precision = Precision::fp32;
  rec.precision_requested = Precision::bf16;
  auto md = training_run_metadata(rec);
  CHECK(md.at("seed") == "3");
  CHECK(md.at("samples") == "16");
  CHECK(md.at("batch") == "2");
  CHECK(md.at("sample_vertices") == "2048");
  CHECK(md.at("sampling") == "random");
  CHECK(md.at("lr_schedule") == "cosine");
  CHECK(md.at("precision") == "fp32");
  CHECK(md.at("precision_requested") == "bf16");
  CHECK_FALSE(md.count("init"));
  CHECK_FALSE(md.count("loss_history"));
  // Written, then read back by a resume: the same run settings.
  models::CheckpointFile f;
  f.metadata = md;
  const RunSettings s = resumed_settings(f, "m.gcm", {});
  CHECK(s.seed == 3);
  CHECK(s.samples == 16);
  CHECK(s.batch == 2);
  CHECK(s.sample_vertices == 2048);
  CHECK(s.sampling == "random");
  CHECK(s.precision == "bf16");
  CHECK(s.lr_schedule == "cosine");
  // A fine-tune records its source; a resumed fine-tune carries that record over.
  models::CheckpointFile source;
  source.metadata = {{"epoch", "5"}};
  RunRecord tuned;
  record_init(tuned, "/abs/a.gcm", &source, nullptr);
  CHECK(tuned.init_path == "/abs/a.gcm");
  CHECK(tuned.init_epoch == "5");
  models::CheckpointFile resumed;
  resumed.metadata = training_run_metadata(tuned);
  RunRecord again;
  record_init(again, "", nullptr, &resumed);
  CHECK(again.init_path == "/abs/a.gcm");
  CHECK(again.init_epoch == "5");
  // The whole record read back in one place (gat info, a resume's history).
  rec.init_path = "/abs/a.gcm", rec.init_epoch = "5", rec.loss_history = "1,0.5,0.25,0.001,1.5,,";
  const RunRecord back = read_run_record(file_of_record(rec), "m.gcm");
  CHECK(back.seed == 3);
  CHECK(back.samples == 16);
  CHECK(back.batch == 2);
  CHECK(back.sample_vertices == 2048);
  CHECK(back.sampling == models::Sampling::random);
  CHECK(back.schedule == models::Schedule::cosine);
  CHECK(back.precision == Precision::fp32);
  CHECK(back.precision_requested == Precision::bf16);
  CHECK(back.init_path == rec.init_path);
  CHECK(back.init_epoch == "5");
  CHECK(back.loss_history == rec.loss_history);
  // Older checkpoints and students: the defaults, the requested precision the one that ran.
  models::CheckpointFile old;
  old.metadata = {{"precision", "bf16"}};
  const RunRecord o = read_run_record(old, "old.gcm");
  CHECK(o.precision == Precision::bf16);
  CHECK(o.precision_requested == Precision::bf16);
  CHECK(o.loss_history.empty());
  CHECK(o.init_path.empty());
  old.metadata = {{"precision", "fp16"}};
  CHECK_THROWS_WITH(read_run_record(old, "old.gcm"), Catch::Contains("old.gcm: metadata precision"));
  old.metadata = {{"sampling", "every"}};
  CHECK_THROWS_WITH(read_run_record(old, "old.gcm"), Catch::Contains("old.gcm: metadata sampling"));
  old.metadata = {{"batch", "2x"}};
  CHECK_THROWS_WITH(read_run_record(old, "old.gcm"), Catch::Contains("old.gcm") && Catch::Contains("batch"));
  const auto d = distillation_metadata(4, "/t/teacher.gcm", 0.25);
  CHECK(d.at("seed") == "4");
  CHECK(d.at("distilled_from") == "/t/teacher.gcm");
  CHECK(d.at("distill_hard") == "0.250000");
}
