// Bones a character lacks although every training character had them
// (character_model.hpp): the checkpoint's record of them, its errors, and
// which bones are reported. gat deform / predict-weights print the warning
// (ctest gat_absent_bones_warning).
#include <catch2/catch.hpp>

#include <algorithm>

#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/error.hpp"
#include "pose_fixtures.hpp"

using namespace gatcore;
using namespace gatcore::character;

TEST_CASE("bone presence: read from the checkpoint's metadata, malformed values refused", "[character][absent_bones]") {
  models::CheckpointFile f;
  CHECK(checkpoint_bone_presence(f, "m.gcm", 3).count.empty());  // older checkpoints: nothing recorded
  f.metadata["bone_presence"] = format_bone_presence({4, 0, 2});
  CHECK(f.metadata["bone_presence"] == "4,0,2");
  CHECK_THROWS_WITH(checkpoint_bone_presence(f, "m.gcm", 3), Catch::Contains("m.gcm") && Catch::Contains("go together"));
  f.metadata["training_characters"] = "4";
  const BonePresence p = checkpoint_bone_presence(f, "m.gcm", 3);
  CHECK(p.count == std::vector<int>{4, 0, 2});
  CHECK(p.characters == 4);
  CHECK_THROWS_WITH(checkpoint_bone_presence(f, "m.gcm", 4), Catch::Contains("3 counts for 4 bones"));
  f.metadata["bone_presence"] = "4,x,2";
  CHECK_THROWS_WITH(checkpoint_bone_presence(f, "m.gcm", 3), Catch::Contains("bad count 'x'"));
  f.metadata["bone_presence"] = "4,5,2";
  CHECK_THROWS_WITH(checkpoint_bone_presence(f, "m.gcm", 3), Catch::Contains("5 characters of 4"));
  f.metadata["bone_presence"] = "4,-1,2";
  CHECK_THROWS_WITH(checkpoint_bone_presence(f, "m.gcm", 3), Catch::Contains("bad count '-1'"));
}

TEST_CASE("unseen_absent_bones: only bones every training character had and this one lacks", "[character][absent_bones]") {
  const Character ch = posefix::humanoid(1);
  std::vector<std::string> bones;
  for (const auto& n : ch.skeleton.names) bones.push_back(normalise_bone_name(n));
  // The model's bones: the humanoid's minus its last joint, plus three it lacks.
  bones.pop_back();
  bones.insert(bones.end(), {"finger4.l", "finger1.l", "tail"});
  const BoneMapping m = map_bones(ch.skeleton, bones, {}, "h");
  BonePresence p;
  p.characters = 5;
  p.count.assign(bones.size(), 5);
  p.count[bones.size() - 2] = 2;  // finger1.l: some training characters lacked it (absent was seen)
  p.count[bones.size() - 1] = 0;  // tail: none had it
  CHECK(unseen_absent_bones(m, bones, p) == std::vector<std::string>{"finger4.l"});
  const std::string w = unseen_absent_bones_warning("h.glb", unseen_absent_bones(m, bones, p), p);
  CHECK_THAT(w, Catch::Contains("h.glb lacks 1 of the model's") && Catch::Contains("all 5 training characters") &&
                    Catch::Contains("(finger4.l)") && Catch::Contains("never saw"));
  CHECK(unseen_absent_bones_warning("h.glb", {}, p).empty());
  CHECK(unseen_absent_bones(m, bones, BonePresence{}).empty());  // not recorded: no claim
  // The character's extra joint (mapped to no bone) is not a missing bone.
  CHECK(std::find(m.unmapped.begin(), m.unmapped.end(), ch.skeleton.names.back()) != m.unmapped.end());
}
