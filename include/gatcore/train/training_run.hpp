#pragma once
// The rules of a training run (gat train): what a resumed run keeps from its
// checkpoint, what a fine-tune (--init) may change, which options apply to
// which model, and the run's record in the checkpoint's metadata ("seed",
// "samples", "batch", "sample_vertices", "sampling", "precision",
// "precision_requested", "lr_schedule", "init", "init_epoch",
// "loss_history"; a distilled student's "distilled_from", "distill_hard"). The checks return the refusal ("" when the run may go
// ahead) so a command can print it and stop before anything is written.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/models/train.hpp"
#include "gatcore/precision.hpp"

namespace gatcore::train {

// What was asked of the run (gat train's options); "" / empty: not given.
struct RunRequest {
  std::string resume;  // a checkpoint to continue
  std::string init;    // a checkpoint to fine-tune from (not with resume)
  std::string data;    // the dataset; empty: the embedded tube data
  std::string loss;    // displacement models: mse | l1; skin-weight models: kl | l1
  bool linear_skip = false;
  std::vector<std::int64_t> pair_scorer;
  float classifier_dropout = -1;                // < 0: not given
  std::string world_columns;                    // use | ignore
  std::vector<std::string> architecture_flags;  // given options that a fine-tune takes from its checkpoint
  std::string keep_best_by;                     // loss | l1
  bool nearest_joint_columns = false;           // --joint-columns nearest:K
};

// The run's data and batching; a resumed run continues with its checkpoint's.
struct RunSettings {
  long seed = 0, samples = 64, batch = 0, sample_vertices = 0;  // 0: the model's default
  std::string sampling, precision, lr_schedule;                 // "": the model's default
  double average_decay = -1;                                    // < 0: the model's default (no averaging)
};

// Before any checkpoint is read: a fine-tune needs a dataset and takes the
// architecture from its checkpoint.
std::string check_request(const RunRequest& r);

// The settings a resumed run continues with: the checkpoint's seed, samples,
// batch, sample vertices and sampling (where recorded), its precision,
// schedule and weight-average decay unless `asked` names one. Throws InvalidArgument naming `path`
// and the key for a value that does not parse.
RunSettings resumed_settings(const models::CheckpointFile& f, const std::string& path, RunSettings asked);

// A resumed run reads the dataset its checkpoint was trained on
// (`checkpoint_data_path`, "" for the embedded tube data); --data may not
// turn a tube model into a dataset one.
std::string check_resumed_data(const std::string& resume, const std::string& checkpoint_data_path,
                               const std::string& data);

// A new model of `cfg` (its kind and task chosen): each option applies to
// the models it names.
std::string check_new_model_options(const models::ModelConfig& cfg, const RunRequest& r);
// The asked architecture options on a new model's config (loss, linear skip,
// pair scorer, classifier dropout).
void apply_architecture_options(models::ModelConfig& cfg, const RunRequest& r);

// A checkpoint's model (resumed or fine-tuned) keeps its architecture.
std::string check_checkpoint_architecture(const models::ModelConfig& cfg, const RunRequest& r);

// The figure --keep-best keeps by ("l1" or "loss"; default: l1 for skin
// weights); `refusal` set when it does not apply to the model.
std::string keep_best_figure(const models::ModelConfig& cfg, const RunRequest& r, std::string* refusal);

// skinweights-any's world-frame columns: a model from a checkpoint keeps
// whether it ignores them (`checkpoint_ignores`); other models take no --world-columns.
std::string check_world_columns(const models::ModelConfig& cfg, const RunRequest& r, bool from_checkpoint,
                                bool checkpoint_ignores);

// The run's record in the checkpoint. `init_from`: the fine-tuned
// checkpoint's file and metadata (for "init" / "init_epoch"); on a resume the
// resumed checkpoint's record of them carries over.
struct RunRecord {
  long seed = 0, samples = 0;
  int batch = 0;
  std::int64_t sample_vertices = 0;
  models::Sampling sampling = models::Sampling::full;
  models::Schedule schedule = models::Schedule::plateau;
  Precision precision = Precision::fp32, precision_requested = Precision::fp32;  // ran, asked
  std::string init_path, init_epoch;  // a fine-tune's source (absolute) and its epoch
  std::string loss_history;           // character::format_history of the epochs so far
};
// The record of a fine-tune (`init`: its source checkpoint) or a resumed
// fine-tune (`resumed`: the checkpoint carrying the record).
void record_init(RunRecord& rec, const std::string& init, const models::CheckpointFile* init_file,
                 const models::CheckpointFile* resumed);
std::map<std::string, std::string> training_run_metadata(const RunRecord& rec);
// The record as a checkpoint holds it (the keys training_run_metadata
// writes); absent keys, in checkpoints from before they existed or of a
// distilled student, read as RunRecord's defaults (precision fp32, the
// requested one that which ran, no history). Throws naming `path` and the
// key for a value that does not parse.
RunRecord read_run_record(const models::CheckpointFile& f, const std::string& path);
// A distilled student's record: its seed, its teacher (recorded absolute) and
// the ground-truth weight ("seed", "distilled_from", "distill_hard").
std::map<std::string, std::string> distillation_metadata(long seed, const std::string& teacher_path, double hard);

}  // namespace gatcore::train
