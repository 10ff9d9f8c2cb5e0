// The model description a checkpoint records (character/inference/model_description.hpp):
// written and read back field for field, older checkpoints read as they were meant, bad values refused.
#include <catch2/catch.hpp>

#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

models::CheckpointFile file_of(const std::map<std::string, std::string>& md) {
  models::CheckpointFile f;
  f.metadata = md;
  return f;
}

}  // namespace

TEST_CASE("model description: a dataset displacement model round trips") {
  ModelDescription d;
  d.features = FeatureKind::densegats;
  d.skeleton = {"hips", "spine", "head"};
  d.nearest_joints = 0;
  d.distortion_scales = {1, 4, 16};
  d.bone_presence = {{2, 1, 2}, 2};
  d.feature_layout = "densegats: ...";
  d.data_path = "/data/d.json";
  d.data_hash = "abc";
  const auto md = model_description_metadata(d);
  CHECK(md.at("features") == "densegats");
  CHECK(md.at("skeleton") == "hips,spine,head");
  CHECK(md.at("joint_columns") == "bones");
  CHECK(md.at("distortion_scales") == "1,4,16");
  CHECK(md.at("bone_presence") == "2,1,2");
  CHECK(md.at("training_characters") == "2");
  CHECK(md.at("data") == "dataset");
  CHECK(md.at("data_path") == "/data/d.json");
  CHECK(md.at("data_hash") == "abc");
  CHECK_FALSE(md.count("world_columns"));
  const ModelDescription r = read_model_description(file_of(md), "m.gcm");
  CHECK(r.features == d.features);
  CHECK(r.skeleton == d.skeleton);
  CHECK(r.nearest_joints == 0);
  CHECK(r.distortion_scales == d.distortion_scales);
  CHECK(r.bone_presence.count == d.bone_presence.count);
  CHECK(r.bone_presence.characters == 2);
  CHECK(r.feature_layout == d.feature_layout);
  CHECK(r.data_path == d.data_path);
  CHECK(r.data_hash == d.data_hash);
  CHECK(r.data == "dataset");
  CHECK_FALSE(r.world_columns_ignored.has_value());
  // The tube data's words, and a file that records none.
  CHECK(read_model_description(file_of(model_description_metadata(ModelDescription{})), "t.gcm").data ==
        "embedded tube character");
  CHECK(read_model_description(file_of({}), "o.gcm").data.empty());
}

TEST_CASE("model description: skin-weight, any-skeleton, nearest-joint and tube models") {
  ModelDescription any;
  any.features = FeatureKind::bone_candidates;
  any.skeleton = {"a", "b"};
  any.world_columns_ignored = true;
  any.data_path = "/d.json";
  auto md = model_description_metadata(any);
  CHECK(md.at("features") == "bone-candidates");
  CHECK(md.at("world_columns") == "ignore");
  CHECK_FALSE(md.count("joint_columns"));  // displacement models only
  CHECK_FALSE(md.count("bone_presence"));
  ModelDescription r = read_model_description(file_of(md), "m.gcm");
  CHECK(r.features == FeatureKind::bone_candidates);
  REQUIRE(r.world_columns_ignored.has_value());
  CHECK(*r.world_columns_ignored);

  ModelDescription nj;
  nj.features = FeatureKind::densegats;
  nj.skeleton = {"a"};
  nj.nearest_joints = 4;
  nj.data_path = "/d.json";
  md = model_description_metadata(nj);
  CHECK(md.at("joint_columns") == "nearest:4");
  CHECK(read_model_description(file_of(md), "m.gcm").nearest_joints == 4);

  ModelDescription tube;
  tube.skeleton = {"upper_arm", "forearm"};
  md = model_description_metadata(tube);
  CHECK(md.at("features") == "tube");
  CHECK(md.at("data") == "embedded tube character");
  CHECK_FALSE(md.count("data_path"));
  r = read_model_description(file_of(md), "t.gcm");
  CHECK(r.features == FeatureKind::tube);
  CHECK(r.data_path.empty());
}

TEST_CASE("model description: older checkpoints and bad values") {
  // Before the "features" key: a dataset model's features follow its task.
  const std::string weights_config = models::ModelConfig::defaults("neuroskinning", 8, 3).to_text();
  CHECK(read_model_description(file_of({{"data_path", "/d.json"}, {"config", weights_config}}), "m").features ==
        FeatureKind::neuroskinning);
  CHECK(read_model_description(file_of({{"data_path", "/d.json"}}), "m").features == FeatureKind::densegats);
  CHECK(read_model_description(file_of({}), "m").features == FeatureKind::tube);
  // An interim version wrote the layout into "features".
  CHECK(read_model_description(file_of({{"features", "densegats: posed position"}}), "m").features ==
        FeatureKind::densegats);
  CHECK_THROWS_WITH(read_model_description(file_of({{"world_columns", "maybe"}}), "m.gcm"),
                    Catch::Contains("m.gcm: metadata 'world_columns'") && Catch::Contains("maybe"));
  CHECK_THROWS_WITH(read_model_description(file_of({{"joint_columns", "nearest:x"}}), "m.gcm"),
                    Catch::Contains("m.gcm: metadata 'joint_columns'"));
  CHECK_THROWS_WITH(read_model_description(
                        file_of({{"skeleton", "a,b"}, {"bone_presence", "1"}, {"training_characters", "1"}}), "m.gcm"),
                    Catch::Contains("1 counts for 2 bones"));
}
