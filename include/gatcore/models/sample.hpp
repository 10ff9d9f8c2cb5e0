#pragma once
// The trainer's input: one character (displacement task: one character in
// one pose) in memory. The character pipeline produces these from
// its datasets; tests build them procedurally.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/ops.hpp"

namespace gatcore::models {

struct Sample {
  std::string name;
  GraphPtr graph;     // mesh graph (undirected, with self-loops)
  Tensor features;    // [n, d] raw (un-normalised) node features
  Tensor target;      // [n, 3] displacements or [n, |B|] skin weights
  // Optional: per vertex, the nearest vertices by geodesic distance, nearest
  // first (the vertex itself first), at least max pool size long. If empty,
  // the trainer uses breadth-first hop distance on `graph` instead.
  std::vector<std::vector<std::int32_t>> geodesic_neighbours;
  Tensor bone_mask;   // optional [1, |B|] 0/1 mask of the character's bones in the super skeleton
  // Optional [n, out_dim] log prior added to the logits of a model with
  // ModelConfig::logit_prior (skinweights-any: log(bone heat + eps) of each
  // candidate); not normalised. Values under a 0 of the mask do not matter.
  Tensor prior;
  // Optional [n, 1] for skin weights whose target columns hold only part of
  // the truth (skinweights-any: the vertex's candidate bones): the share of
  // the vertex's true weights they hold; the target rows are those weights
  // renormalised. Trainer::validate's L1 then counts the rest as error, so
  // it equals the L1 over the character's joints (gat eval's). Absent: 1.
  Tensor target_mass;
  // Optional, per vertex: the target column of the artist's dominant joint,
  // -1 where no column holds it (skinweights-any: a vertex whose largest
  // weight is on a joint outside its candidates). Trainer::validate's
  // dominant-bone accuracy then matches gat eval's. Absent: the largest
  // target column of the row.
  std::vector<std::int32_t> target_dominant;
};

// Per-column feature normalisation (z-score) and a scalar target scale for
// displacements; stored in checkpoints with the model. A column that was
// constant over the training data gets inv_std 0: the model never saw it
// vary, so at inference it stays at its training value (e.g. the distance
// column of a bone no training character has, filled by a new character's
// skeleton, would otherwise feed weights no gradient ever reached).
struct Normaliser {
  Tensor mean, inv_std;     // [1, d]
  float target_scale = 1.f; // targets are multiplied by it for training; predictions divided

  bool defined() const { return mean.defined(); }
  static Normaliser fit(const std::vector<Sample>& samples, bool scale_targets);
  Tensor apply(const Tensor& features) const;  // a new tensor
};

}  // namespace gatcore::models
