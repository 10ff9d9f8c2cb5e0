// Samples for the trainer from a dataset of the character pipeline
// (character/data/training_data.hpp): procedural characters, both tasks, a few
// epochs of tiny models, checkpoint metadata, bad files.
#include <catch2/catch.hpp>

#include <filesystem>

#include <unistd.h>
#include <fstream>
#include <set>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/models/train.hpp"

using namespace gatcore;
using namespace gatcore::character;
using namespace gatcore::models;

namespace {

std::string temp_dir() {
  // One folder per process: ctest -j runs this binary's test cases as
  // separate processes at once, and they write files of the same names.
  const auto dir = std::filesystem::temp_directory_path() /
                   ("gatcore_training_data_tests_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

std::string write_small_dataset(std::vector<int> distortion_scales = {}) {
  DatasetDescription s;
  s.distortion_scales = std::move(distortion_scales);
  s.random_poses = 2;
  s.subsample = 200;
  s.seed = 3;
  s.validation = 0.25f;
  s.test = 0.25f;
  s.delta_mush = {5, 0.5f};
  const DatasetDescription d = describe_dataset(
      {"procedural:humanoid:0", "procedural:humanoid:1", "procedural:creature:2", "procedural:humanoid:3"}, {}, s);
  const std::string path = temp_dir() + "/small.json";
  save_dataset(path, d);
  return path;
}

}  // namespace

TEST_CASE("displacement and skin-weight samples from a dataset") {
  const std::string path = write_small_dataset();
  const TrainingData td = load_training_data(path);
  CHECK(td.hash == file_hash(path));
  CHECK(td.hash.size() == 16);
  REQUIRE(td.characters.size() == 4);
  const std::int32_t B = td.super.num_bones();
  CHECK(B > 0);
  CHECK(td.feature_dim(Task::displacement) == 6 + B);
  CHECK(td.feature_dim(Task::weights) == 6 + B);
  CHECK(td.description.split.train.size() == 2);

  // Displacement: one sample per pose, windows of `subsample` vertices.
  const auto disp = training_samples(td, Task::displacement, DatasetPart::train, 0);
  REQUIRE(disp.size() == 4);  // 2 characters x 2 random poses
  for (const Sample& s : disp) {
    CHECK(s.features.rows() == 200);
    CHECK(s.features.cols() == 6 + B);
    CHECK(s.target.rows() == 200);
    CHECK(s.target.cols() == 3);
    CHECK(s.graph->num_nodes == 200);
  }
  const auto again = training_samples(td, Task::displacement, DatasetPart::train, 0);
  CHECK(again[1].features.to_vector() == disp[1].features.to_vector());
  const auto other = training_samples(td, Task::displacement, DatasetPart::train, 1);
  CHECK(other[0].features.to_vector() != disp[0].features.to_vector());
  CHECK(training_samples(td, Task::displacement, DatasetPart::train, 0, 1, 1).size() == 2);

  // Skin weights: one sample per character, the whole mesh.
  const auto w = training_samples(td, Task::weights, DatasetPart::train, 0, 16);
  REQUIRE(w.size() == 2);
  for (const Sample& s : w) {
    const std::int64_t n = s.features.rows();
    CHECK(s.features.cols() == 6 + B);
    CHECK(s.target.cols() == B);
    REQUIRE(s.bone_mask.defined());
    CHECK(s.bone_mask.cols() == B);
    REQUIRE(std::int64_t(s.geodesic_neighbours.size()) == n);
    for (std::int64_t i = 0; i < n; i += 37) {
      REQUIRE(!s.geodesic_neighbours[std::size_t(i)].empty());
      CHECK(s.geodesic_neighbours[std::size_t(i)][0] == i);
      CHECK(s.geodesic_neighbours[std::size_t(i)].size() <= 16);
      double sum = 0;
      for (std::int32_t b = 0; b < B; ++b) {
        sum += s.target.at(i, b);
        if (s.target.at(i, b) > 0.f) CHECK(s.bone_mask.at(0, b) == 1.f);
      }
      CHECK(sum == Approx(1.0).epsilon(1e-4));
    }
  }
}

TEST_CASE("distortion scales add 3 displacement columns per scale, not weight columns") {
  const std::string path = write_small_dataset({1, 4});
  const TrainingData td = load_training_data(path);
  CHECK(td.description.distortion_scales == std::vector<int>{1, 4});
  const std::int32_t B = td.super.num_bones();
  CHECK(td.feature_dim(Task::displacement) == 6 + B + 6);
  CHECK(td.feature_dim(Task::weights) == 6 + B);
  const auto disp = training_samples(td, Task::displacement, DatasetPart::train, 0);
  REQUIRE(disp.size() == 4);
  double distortion = 0;
  for (const Sample& s : disp) {
    REQUIRE(s.features.cols() == 6 + B + 6);
    for (std::int64_t i = 0; i < s.features.rows(); ++i)
      for (std::int64_t c = 6 + B; c < s.features.cols(); ++c) distortion += std::abs(s.features.at(i, c));
  }
  CHECK(distortion > 0);  // random poses bend joints
  const auto w = training_samples(td, Task::weights, DatasetPart::train, 0, 4);
  REQUIRE(!w.empty());
  CHECK(w[0].features.cols() == 6 + B);
  // The full-mesh sample of evaluation has the same columns.
  const std::int32_t t0 = td.description.split.test[0];
  CHECK(densegats_full_sample(td, t0, td.characters[std::size_t(t0)].rest).features.cols() == 6 + B + 6);
}

TEST_CASE("tiny models train on a dataset and checkpoints record it") {
  const std::string path = write_small_dataset({2, 8});
  const TrainingData td = load_training_data(path);
  for (const std::string name : {"densegats", "neuroskinning"}) {
    INFO("model " << name);
    ModelConfig c = ModelConfig::defaults(name, 0);
    c.in_dim = td.feature_dim(c.task);
    if (c.task == Task::weights) c.out_dim = td.super.num_bones();
    if (name == "densegats") {
      c.modules = 1;
      c.blocks = 1;
      c.heads = 2;
      c.head = {32};
    } else {
      c.stage1 = {16};
      c.gc_heads = {1, 1, 1};
      c.gc_dims = {8, 8, 8};
      c.gc_pool = {4, 6, 8};
      c.global_mlp = {32};
      c.classifier = {32};
    }
    auto m = make_model(c, 1);
    int k = 1;
    for (int j : m->pool_sizes()) k = std::max(k, j);
    const auto train = training_samples(td, c.task, DatasetPart::train, 0, k);
    const auto val = training_samples(td, c.task, DatasetPart::validation, 0, k);
    REQUIRE(!train.empty());
    REQUIRE(!val.empty());
    TrainOptions o = TrainOptions::defaults_for(c);
    o.batch_size = 2;
    o.sample_vertices = 200;
    Trainer t(*m, o, Normaliser::fit(train, c.task == Task::displacement));
    for (int e = 0; e < 2; ++e) {
      const EpochStats st = t.run_epoch(e == 0 ? train : training_samples(td, c.task, DatasetPart::train, e, k), val);
      CHECK(std::isfinite(st.train_loss));
      CHECK(std::isfinite(st.val_loss));
    }
    const std::string ckpt = temp_dir() + "/" + name + ".gcm";
    save_checkpoint(ckpt, *m, t.normaliser(), &t,
                    {{"data_path", path}, {"data_hash", td.hash}, {"skeleton", joined_bone_names(td.super)}});
    const LoadedModel l = load_checkpoint(ckpt);
    CHECK(l.file.metadata.at("data_hash") == file_hash(path));
    CHECK(l.file.metadata.at("skeleton") == joined_bone_names(td.super));
    const auto test = training_samples(td, c.task, DatasetPart::test, 0, k, 1);
    REQUIRE(!test.empty());
    const Tensor y = predict(*l.model, test[0], l.norm, c.task == Task::weights ? c.top_k : 0);
    CHECK(y.rows() == test[0].features.rows());
  }
}

TEST_CASE("bad dataset files name the file") {
  const std::string missing = temp_dir() + "/no_such_dataset.json";
  CHECK_THROWS_WITH(load_training_data(missing), Catch::Matchers::Contains("no_such_dataset.json"));
  const std::string garbage = temp_dir() + "/malformed_dataset.json";
  std::ofstream(garbage) << "{\"format\": \"gatcore-dataset\", \"version\": 1, ";
  CHECK_THROWS_WITH(load_training_data(garbage), Catch::Matchers::Contains("malformed_dataset.json"));
  const std::string badchar = temp_dir() + "/badchar_dataset.json";
  {
    DatasetDescription d = describe_dataset({"procedural:humanoid:0", "procedural:dragon:1"}, {});
    save_dataset(badchar, d);
  }
  CHECK_THROWS_WITH(load_training_data(badchar), Catch::Matchers::Contains("badchar_dataset.json") &&
                                                     Catch::Matchers::Contains("procedural:dragon:1"));
}
