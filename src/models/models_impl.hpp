#pragma once
// Factories of the model families (one .cpp each).
#include <memory>

#include "gatcore/models/model.hpp"

namespace gatcore::models::detail {
std::unique_ptr<Model> make_densegats(const ModelConfig& cfg, std::uint64_t seed);
std::unique_ptr<Model> make_origat(const ModelConfig& cfg, std::uint64_t seed);
std::unique_ptr<Model> make_neuroskinning(const ModelConfig& cfg, std::uint64_t seed);
std::unique_ptr<Model> make_fc(const ModelConfig& cfg, std::uint64_t seed);
std::unique_ptr<Model> make_pointnet(const ModelConfig& cfg, std::uint64_t seed);
}  // namespace gatcore::models::detail
