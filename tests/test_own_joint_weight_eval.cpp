// Skin-weight metrics of methods on each character's own joints
// (character/eval/own_joint_weight_eval.hpp): bone heat, and a
// skinweights-any model mixed with bone heat, on a small procedural dataset.
#include <catch2/catch.hpp>

#include <filesystem>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/eval/own_joint_weight_eval.hpp"
#include "gatcore/character/features/bone_candidates.hpp"
#include "gatcore/models/config.hpp"
#include "small_dataset.hpp"

using namespace gatcore;
using namespace gatcore::character;
namespace fs = std::filesystem;

TEST_CASE("own-joint weight eval: bone heat, and a model mixed with bone heat at share 1, give the same table (to rounding)") {
  const fs::path dir = fs::temp_directory_path() / "gatcore_test_own_joint_weight_eval";
  const std::string data = testing::write_small_dataset(dir);
  const TrainingData td = load_training_data(data);
  WeightEvalOptions eo;
  eo.poses = 1;
  OwnJointMethod heat;  // bone heat's defaults: top 4, min weight 0.01
  std::vector<std::string> seen;
  const auto per = evaluate_own_joint_weights(td, DatasetPart::train, heat, eo,
                                              [&](const CharacterWeightEval& r, double seconds, int joints) {
                                                seen.push_back(r.name);
                                                CHECK(seconds >= 0);
                                                CHECK(joints > 0);
                                              });
  REQUIRE(per.size() == td.part(DatasetPart::train).size());
  CHECK(seen.size() == per.size());
  for (std::size_t i = 0; i < per.size(); ++i) {
    CHECK(per[i].name == td.description.characters[std::size_t(td.part(DatasetPart::train)[i])]);
    CHECK(per[i].vertices == td.characters[std::size_t(td.part(DatasetPart::train)[i])].character.mesh.num_vertices());
    // Bone heat is not the artist's weights, and L1 of two weight sets lies in [0, 2].
    CHECK(per[i].weights.l1_mean > 0);
    CHECK(per[i].weights.l1_mean <= 2);
  }

  // An untrained skinweights-any model: at share 1 the mix is bone heat itself.
  models::ModelConfig cfg = models::ModelConfig::defaults(
      "skinweights-any", bone_candidate_feature_dim(kDefaultCandidates), kDefaultCandidates);
  cfg.blocks = 1;
  auto model = models::make_model(cfg, 3);
  model->fold_batch_norm();
  const models::Normaliser norm;
  OwnJointMethod mixed;
  mixed.model = model.get();
  mixed.norm = &norm;
  mixed.heat_blend = 1.0f;
  mixed.bone_heat.min_weight = 0.0f;  // as gat eval's model path: the mix applies bone heat's own
  const auto per_mixed = evaluate_own_joint_weights(td, DatasetPart::train, mixed, eo);
  REQUIRE(per_mixed.size() == per.size());
  for (std::size_t i = 0; i < per.size(); ++i) {
    CHECK(per_mixed[i].weights.l1_mean == Approx(per[i].weights.l1_mean).epsilon(1e-6));  // the mix rounds once more
    CHECK(per_mixed[i].dominant == per[i].dominant);
  }
  // The model alone differs from bone heat.
  mixed.heat_blend = 0.0f;
  const auto per_model = evaluate_own_joint_weights(td, DatasetPart::train, mixed, eo);
  bool any_differs = false;
  for (std::size_t i = 0; i < per.size(); ++i) any_differs |= per_model[i].weights.l1_mean != per[i].weights.l1_mean;
  CHECK(any_differs);
}
