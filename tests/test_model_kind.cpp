// ModelKind: names round trip, unknown names are refused naming them, and the
// capabilities agree with what each kind's default config and model do.
#include <catch2/catch.hpp>

#include <set>
#include <string>

#include "gatcore/error.hpp"
#include "gatcore/models/config.hpp"
#include "gatcore/models/deploy.hpp"
#include "gatcore/models/model.hpp"
#include "gatcore/models/model_kind.hpp"

using namespace gatcore;
using namespace gatcore::models;

TEST_CASE("model kinds: every name parses back to its kind, names are distinct") {
  std::set<std::string> names;
  for (ModelKind k : all_model_kinds()) {
    const std::string n = model_kind_name(k);
    CHECK(names.insert(n).second);
    REQUIRE(parse_model_kind(n).has_value());
    CHECK(*parse_model_kind(n) == k);
    CHECK(model_kind_from_name(n) == k);
  }
  CHECK(names.size() == 9);
  CHECK(model_names().size() == all_model_kinds().size());
}

TEST_CASE("model kinds: unknown names are refused, naming the name and the known ones") {
  CHECK_FALSE(parse_model_kind("densegats2").has_value());
  CHECK_FALSE(parse_model_kind("").has_value());
  CHECK_FALSE(parse_model_kind("DenseGATs").has_value());  // names are exact, as written in checkpoints
  CHECK_THROWS_WITH(model_kind_from_name("nope"), Catch::Contains("unknown model 'nope'") &&
                                                      Catch::Contains("skinweights-any") && Catch::Contains("pointnet"));
  ModelConfig c;
  c.name = "nope";
  CHECK_THROWS_AS(c.kind(), InvalidArgument);
}

TEST_CASE("model kinds: capabilities match each kind's default config") {
  for (ModelKind k : all_model_kinds()) {
    const ModelConfig c = ModelConfig::defaults(model_kind_name(k), 8, predicts_skin_weights(k) ? 5 : 3);
    INFO(model_kind_name(k));
    CHECK(c.kind() == k);
    CHECK(predicts_displacement(k) == (c.task == Task::displacement));
    CHECK(predicts_skin_weights(k) == (c.task == Task::weights));
    CHECK(deployable(c) == deployable(k));
  }
  CHECK(deployable(ModelKind::origat));
  CHECK_FALSE(deployable(ModelKind::neuroskinning));
  CHECK(any_skeleton(ModelKind::skinweights_any));
  CHECK_FALSE(any_skeleton(ModelKind::neuroskinning));
  CHECK(is_densegats_family(ModelKind::densegats_nodense));
  CHECK_FALSE(is_densegats_family(ModelKind::origat));
  CHECK(uses_neuroskinning_features(ModelKind::pointnet));
  CHECK_FALSE(uses_neuroskinning_features(ModelKind::skinweights_any));
}
