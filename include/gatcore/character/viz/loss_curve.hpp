#pragma once
// Training loss history (what gat train records per epoch): a compact string
// for the checkpoint's metadata (so a resumed run continues its curve), a CSV
// table and a PNG loss curve (train and validation loss, log y), written
// atomically so they can be rewritten after every epoch.
#include <map>
#include <string>
#include <vector>

namespace gatcore::character {

struct LossRecord {
  int epoch = 0;
  double train = 0, val = -1;  // val < 0: no validation set
  double lr = 0, seconds = 0;
  double val_l1 = -1;  // skin-weight models: validation L1 (models::Evaluation); < 0: not measured
  double val_dominant = -1;  // and the fraction of vertices with the right dominant bone; < 0: not measured
};

// "epoch:train:val:lr:seconds[:val_l1[:val_dominant]];..." (checkpoint
// metadata "loss_history"; the last two only where measured, so older
// checkpoints read the same).
std::string format_history(const std::vector<LossRecord>& h);
// Throws InvalidArgument naming `what` for a malformed string.
std::vector<LossRecord> parse_history(const std::string& s, const std::string& what);

// "model.gcm" -> "model.loss.png".
std::string default_curve_path(const std::string& checkpoint);
// "curve.png" -> "curve.csv" (else the path + ".csv").
std::string history_csv_path(const std::string& png);
// Writes the CSV (epoch,train_loss,val_loss,lr,seconds,val_l1,val_dominant)
// and the PNG.
void write_loss_outputs(const std::vector<LossRecord>& h, const std::string& png);

}  // namespace gatcore::character
