#pragma once
// The embedded data of gat train / gat eval / gat demo without a dataset:
// the two-bone tube of tube.hpp as an arm (shoulder at y = 0, elbow at 1,
// wrist at 2; an elliptic section, smoothstep weights across the elbow).
//  - displacement task: the arm in random bend / twist poses; features of
//    the LBS-posed mesh, target = reference - LBS (as DenseGATs), the
//    reference being angle-blended skinning, which keeps the elbow's volume
//    where LBS collapses it (the candy-wrapper artefact);
//  - weights task: arms of varying resolution and radius in the rest pose,
//    target = their two-bone weights (as NeuroSkinning).
// Features per vertex: position (3), area-weighted normal (3), distance to
// the shoulder, the elbow and the posed wrist (3).
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/character/data/tube.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/models/sample.hpp"

namespace gatcore::character {

inline constexpr std::int64_t kTubeFeatures = 9;
inline constexpr std::int64_t kTubeBones = 2;
// The bones a tube model's columns follow ("upper_arm", "forearm").
std::vector<std::string> tube_bone_names();

// The arm's tube (`rings` x `segments`, section radius `radius`).
TubeOptions tube_arm_options(int rings = 24, int segments = 16, float radius = 0.25f);

// `count` samples of `task`, deterministic per seed.
std::vector<models::Sample> tube_samples(models::Task task, int count, std::uint64_t seed);

}  // namespace gatcore::character
