#pragma once
// The description a model trained on a dataset records in its checkpoint
// (inference/model_description.hpp): its features, the dataset's super
// skeleton, joint columns, distortion scales, which bones every training
// character had, and the dataset.
#include <string>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::character {

// A model of `cfg` trained on `td` (read from `data_path`; recorded absolute)
// with the normaliser `norm` (for an any-skeleton model: which columns it ignores).
ModelDescription describe_dataset_model(const TrainingData& td, const std::string& data_path,
                                        const models::ModelConfig& cfg, const models::Normaliser& norm);

// Whether a checkpoint's model (resumed from `resume`, or fine-tuned from
// `from`; `trained`: its description) continues on `td` (read from `data`):
// a resumed run's dataset unchanged (its hash), the joint columns the
// checkpoint has (`asked_nearest`: --joint-columns, -1 if not given), and for
// bone columns the same super skeleton. Returns the refusal, "" when it fits.
std::string check_checkpoint_dataset(const TrainingData& td, const std::string& data, const ModelDescription& trained,
                                     const std::string& resume, const std::string& from, int asked_nearest);

}  // namespace gatcore::character
