// Writes the fuzzers' seed corpora with the project's own exporters:
//   make_corpus DIR  ->  DIR/{checkpoint,bvh,asf,pc2,gltf,dataset}/...
// Small inputs on purpose (libFuzzer mutates faster on short files).
#include <filesystem>
#include <fstream>
#include <iterator>

#include "character_fixtures.hpp"
#include "checkpoint_v1.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const fs::path out = argv[1];
  for (const char* d : {"checkpoint", "bvh", "asf", "pc2", "gltf", "dataset"}) fs::create_directories(out / d);

  // Checkpoints: a small real model with training state, and a two-tensor file.
  models::ModelConfig cfg = models::ModelConfig::defaults("fc", 4, 3);
  cfg.fc = {8};
  auto m = models::make_model(cfg, 1);
  models::save_checkpoint((out / "checkpoint" / "fc.gcm").string(), *m, models::Normaliser{});
  {  // the same as format version 1 (gat upgrade-checkpoint's input)
    std::ifstream is(out / "checkpoint" / "fc.gcm", std::ios::binary);
    const std::string v2{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
    std::ofstream(out / "checkpoint" / "fc_v1.gcm", std::ios::binary) << testutil::version_1_bytes(v2);
  }
  models::CheckpointFile f;
  f.metadata["config"] = "name = fc";
  f.tensors.emplace_back("a", Tensor::full(2, 3, 0.5f));
  f.tensors.emplace_back("b", Tensor::full(1, 1, -1.0f));
  models::write_checkpoint_file((out / "checkpoint" / "two.gcm").string(), f);

  // BVH: the procedural swing (3 frames) and a minimal one.
  std::ofstream(out / "bvh" / "swing.bvh") << character::procedural_swing_bvh(3);
  std::ofstream(out / "bvh" / "min.bvh") << "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation "
                                            "Yrotation\nEnd Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 2\n"
                                            "Frame Time: 0.5\n1 2 3\n4 5 6\n";

  // ASF / AMC (fuzz_asf.cpp: the skeleton, then "---amc---" and the motion):
  // two bones with tilted axes, partial dofs, limits over several lines.
  {
    const std::string asf =
        "# seed\n:version 1.10\n:name seed\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:documentation\n"
        "  seed\n:root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n"
        ":bonedata\n  begin\n    id 1\n    name lfemur\n    direction 0 -1 0\n    length 7.5\n"
        "    axis 0 0 20 XYZ\n    dof rx ry rz\n    limits (-160.0 20.0)\n           (-70.0 70.0)\n"
        "           (-60.0 70.0)\n  end\n  begin\n    id 2\n    name ltibia\n    direction 0 -1 0\n"
        "    length 7.2\n    axis 0 0 20 XYZ\n    dof rx\n    limits (-10.0 170.0)\n  end\n"
        ":hierarchy\n  begin\n    root lfemur\n    lfemur ltibia\n  end\n";
    std::ofstream(out / "asf" / "skeleton.asf") << asf;
    std::ofstream(out / "asf" / "pair.txt") << asf << "---amc---\n:FULLY-SPECIFIED\n:DEGREES\n1\n"
                                                      "root 0 17 0 0 0 0\nlfemur 10 0 -5\nltibia 30\n2\n"
                                                      "root 0 17 1 0 5 0\nlfemur 20 0 -5\n";
  }

  // Point cache.
  character::PointCache pc;
  pc.num_points = 3;
  pc.samples = {{0, 1, 2, 3, 4, 5, 6, 7, 8}, {1, 1, 1, 2, 2, 2, 3, 3, 3}};
  character::write_point_cache((out / "pc2" / "small.pc2").string(), pc);

  // glTF: the test tube character re-exported by save_gltf_character (binary and JSON).
  const std::string tube = charfix::write_temp("fuzz_tube.glb", charfix::skinned_glb());
  const character::Character ch = character::load_gltf(tube);
  character::save_gltf_character(ch, (out / "gltf" / "tube.glb").string());
  character::save_gltf_character(ch, (out / "gltf" / "tube.gltf").string());
  // One skin per mesh, each relative to its own mesh (the importer maps them into one bind space).
  charfix::GlbOptions split;
  split.split_skin = true;
  const std::string split_glb = charfix::skinned_glb(split);
  std::ofstream(out / "gltf" / "split_skin.glb", std::ios::binary).write(split_glb.data(), std::streamsize(split_glb.size()));

  // Dataset descriptions (with and without a joint-limit table).
  character::DatasetDescription s;
  s.random_poses = 4;
  s.distortion_scales = {1, 4};
  const auto d = character::describe_dataset({"procedural:humanoid:0", "procedural:creature:1", "procedural:humanoid:2"},
                                             {}, s);
  character::save_dataset((out / "dataset" / "plain.json").string(), d);
  auto e = d;
  e.joint_limits = character::load_joint_limits("humanoid");
  character::save_dataset((out / "dataset" / "limits.json").string(), e);
  return 0;
}
