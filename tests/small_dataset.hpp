#pragma once
// A small procedural dataset file for tests of the evaluation harnesses:
// three humanoids and a creature, one random pose each, 300-vertex samples,
// Delta Mush at 5 iterations, one validation and one test character.
#include <filesystem>
#include <string>

#include "gatcore/character/data/dataset.hpp"

namespace gatcore::testing {

// Writes it as `dir`/d.json (dir created) and returns the path.
inline std::string write_small_dataset(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "d.json").string();
  character::DatasetDescription s;
  s.random_poses = 1;
  s.subsample = 300;
  s.delta_mush.iterations = 5;
  s.validation = 0.25f;
  s.test = 0.25f;
  s.seed = 4;
  character::save_dataset(path, character::describe_dataset({"procedural:humanoid:0", "procedural:humanoid:1",
                                                             "procedural:creature:2", "procedural:humanoid:3"},
                                                            {}, s));
  return path;
}

}  // namespace gatcore::testing
