#pragma once
// Checkpoints ("model.gcm"): a safetensors file, so PyTorch users can read
// the weights with `safetensors.torch.load_file`, with gatcore's metadata in
// the header's "__metadata__" block.
//
// Layout (all integers little-endian):
//   u64 N                      header length in bytes (at most 100 MiB)
//   N bytes                    JSON header, space-padded to a multiple of 8:
//     {"__metadata__": {"format": "gatcore-checkpoint", "format_version": "2",
//                       "checksum": "<FNV-1a 64, hex; see below>",
//                       "config": "<ModelConfig::to_text()>", ...},
//      "<tensor name>": {"dtype": "F32", "shape": [rows, cols], "data_offsets": [begin, end]}, ...}
//   data section               raw row-major float32 tensors at their offsets
// Tensor names: the model's parameters and buffers (BatchNorm running stats)
// under their registry names; "norm.mean", "norm.inv_std" (feature
// normalisation); "optim.m.<param>", "optim.v.<param>" (Adam moments);
// "optim.raw.<param or buffer>" (a run that averages its weights: the last
// step's).
// Metadata (strings): config, target_scale, epoch, lr, adam_steps, rng,
// model_rng, plateau_best, plateau_has_best, plateau_bad_epochs, and any extra
// entries of the caller (e.g. skeleton bone names).
//
// A file is recognised as a checkpoint by its metadata "format" key, not by a
// byte prefix. The checksum covers every metadata entry but itself (sorted by
// key) and every tensor sorted by name (name, shape, data), so it does not
// depend on the order or offsets of tensors in the file: a checkpoint re-saved
// by Python (`safetensors.*.save_file(load_file(x), metadata=...)` with the
// same metadata) still loads, and an edited header (lr, epoch, ...) does not.
// Metadata numbers are parsed strictly (whole string, finite, in range).
//
// Writes are atomic (write_file_atomic: temp file, fsync, rename). Reading
// checks the format key, version, sizes, offsets (the tensors must tile the
// data section), the checksum, and every tensor's name and shape against the
// model; errors are CheckpointError naming the file and the problem. A model
// is returned only if everything loaded.
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "gatcore/error.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/sample.hpp"
#include "gatcore/nn/init.hpp"

namespace gatcore::models {

struct CheckpointError : Error {
  using Error::Error;
};

// The raw file: metadata and named tensors (in file order).
struct CheckpointFile {
  std::map<std::string, std::string> metadata;
  std::vector<std::pair<std::string, Tensor>> tensors;
  const Tensor* find(const std::string& name) const;
};

void write_checkpoint_file(const std::string& path, const CheckpointFile& f);
CheckpointFile read_checkpoint_file(const std::string& path);
// The same, in memory (`path` only names the source in errors).
std::string checkpoint_bytes(const CheckpointFile& f);
CheckpointFile parse_checkpoint(std::string_view bytes, const std::string& path);

// Saves the model (parameters + buffers) and the normaliser. The model may
// live on any device (tensors are downloaded before writing). load_checkpoint
// returns a CPU model. The trainer's state (to resume training) is saved by
// train.hpp's save_checkpoint, which adds it to model_checkpoint's contents.
void save_checkpoint(const std::string& path, const Model& model, const Normaliser& norm,
                     const std::map<std::string, std::string>& extra = {});
// What save_checkpoint writes, in memory (`path` only names the file in errors).
CheckpointFile model_checkpoint(const Model& model, const Normaliser& norm,
                                const std::map<std::string, std::string>& extra = {},
                                const std::string& path = "checkpoint");

struct LoadedModel {
  std::unique_ptr<Model> model;
  Normaliser norm;
  CheckpointFile file;  // raw contents, for metadata and resume
};
LoadedModel load_checkpoint(const std::string& path);

// Reads `in`, a checkpoint of format version 1 (whose checksum covered the
// data section only: it is verified as such) or 2, and writes it to `out` as
// version 2 (the checksum over metadata and tensors), atomically; the result
// must load as a model (load_checkpoint), else `out` is removed and the error
// thrown. Returns the version read. The metadata is taken as the file has
// it: version 1 could not tell an edited header, so upgrade only files you
// trust (`gat upgrade-checkpoint`).
int upgrade_checkpoint(const std::string& in, const std::string& out);
// The same from memory: the verified, loadable file as version 2 (written by
// write_checkpoint_file); `version` (optional) receives the version read.
CheckpointFile upgrade_checkpoint_bytes(std::string_view bytes, const std::string& path, int* version = nullptr);

// Metadata values, strictly: the whole string, finite, within [lo, hi] (an
// integer; "0" or "1"); otherwise CheckpointError naming `path`, the key and
// the value (never a NaN learning rate resumed into an all-NaN model).
double metadata_number(const std::map<std::string, std::string>& meta, const std::string& key, double lo, double hi,
                       const std::string& path);
std::int64_t metadata_integer(const std::map<std::string, std::string>& meta, const std::string& key, std::int64_t lo,
                              std::int64_t hi, const std::string& path);
bool metadata_flag(const std::map<std::string, std::string>& meta, const std::string& key, const std::string& path);
// How numbers and RNG states are written into metadata (17 digits; the
// engine's stream form), what the readers above take back exactly.
std::string metadata_text(double v);
std::string metadata_text(nn::Rng& rng);

}  // namespace gatcore::models
