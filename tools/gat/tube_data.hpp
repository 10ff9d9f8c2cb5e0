#pragma once
// Training samples from the embedded tube character (the default data of
// `gat train` / `gat eval` until the character pipeline's datasets exist):
//  - displacement task: the tube in random bend/twist poses; features of the
//    LBS-posed mesh, target = reference − LBS (as DenseGATs);
//  - weights task: tubes of varying resolution and radius in the rest pose,
//    target = their two-bone skin weights (as NeuroSkinning), 2 bones.
#include <cstdint>
#include <vector>

#include "gatcore/models/sample.hpp"
#include "gatcore/models/config.hpp"

namespace demo {

std::vector<gatcore::models::Sample> tube_samples(gatcore::models::Task task, int count, std::uint64_t seed);
constexpr std::int64_t kTubeFeatures = 9;
constexpr std::int64_t kTubeBones = 2;

}  // namespace demo
