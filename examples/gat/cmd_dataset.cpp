// `gat dataset build -o DATASET.json [options] CHARACTER|DIR ... [--motion M.bvh ...]`:
// checks that every character (and motion) loads, then writes the dataset
// description the trainer streams samples from (see dataset.hpp).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/file_targets.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace gat {

namespace {

void usage(std::FILE* f) {
  std::fprintf(f,
               "usage: gat dataset build -o DATASET.json [options] CHARACTER|DIR ... [--motion M.bvh ...]\n"
               "  CHARACTER: .glb/.gltf/.fbx/.dae file, a directory of them, or procedural:humanoid:SEED /\n"
               "             procedural:creature:SEED\n"
               "  --random-poses N (32)  --pose-angle RAD (0.5)  --motion-stride K (4)  --seed S (0)\n"
               "  --subsample M (1000)   --validation F (0.1)    --test F (0.1)\n"
               "  --dm-iterations I (10) --dm-step S (0.5)       --skip-bad (skip unreadable characters)\n"
               "  --distortion-scales K1,K2,... (1,4,16)  DenseGATs input columns: the skinning distortion of\n"
               "             the mesh's detail coordinates at these smoothing scales (see\n"
               "             include/gatcore/character/deform/detail_distortion.hpp); 'none' = the paper's features only\n"
               "  --joint-limits FILE|humanoid  per-joint random-pose limits (JSON table, see\n"
               "             include/gatcore/character/rig/joint_limits.hpp; 'humanoid' = the built-in table);\n"
               "             recorded in the dataset; without it every joint axis gets +-pose-angle\n"
               "  --reference delta_mush|arap  the built-in reference deformer the targets come from (default\n"
               "             delta_mush); arap: as-rigid-as-possible on LBS (include/gatcore/character/deform/arap.hpp)\n"
               "             with --arap-iterations I (10) and --arap-handle-weight W (0.95)\n"
               "  --target CHARACTER TARGET MOTION  the character's own per-frame targets instead: TARGET a .pc2\n"
               "             point cache (or comma-separated .pc2, one per mesh, in the file's order) or a glTF\n"
               "             with a morph-target animation (what gat deform writes); MOTION the BVH that drove it,\n"
               "             or clip:NAME (the character file's own animation). Target frame k is motion frame\n"
               "             FIRST + k * (the .pc2 sample rate); FIRST: the .pc2 start frame, 0 for a glTF, or\n"
               "             --target-first-frame F after the --target. --target-animation NAME: the glTF's\n"
               "             morph animation (default 'deform'). Vertex and frame counts are checked; the character\n"
               "             trains and evaluates on its target frames only (every --motion-stride-th per epoch)\n"
               "  --test-characters A,B,...  --validation-characters C,...  an explicit split instead of the\n"
               "             seeded one: each entry names one character by the end of its path (e.g.\n"
               "             modular_men/Punk.glb); the rest train\n"
               "usage: gat dataset export-character CHARACTER -o OUT.glb\n"
               "  writes a dataset character (e.g. procedural:humanoid:5) as a skinned glTF file\n"
               "usage: gat dataset export-motion procedural:swing[:FRAMES] -o OUT.bvh\n"
               "  writes the built-in procedural swing motion (CMU joint names, 30 fps, default 24 frames)\n");
}

// `gat dataset export-motion procedural:swing[:N] -o OUT.bvh`: a motion for
// the examples and tests that needs no downloaded data.
int export_motion(int argc, char** argv) {
  std::string entry, out;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-o" && i + 1 < argc) out = argv[++i];
    else if (!a.empty() && a[0] != '-' && entry.empty()) entry = a;
    else throw gatcore::InvalidArgument("export-motion: unknown or extra argument '" + a + "'");
  }
  if (entry.empty() || out.empty()) {
    usage(stderr);
    return 2;
  }
  const std::string prefix = "procedural:swing";
  if (entry.compare(0, prefix.size(), prefix) != 0 || (entry.size() > prefix.size() && entry[prefix.size()] != ':'))
    throw gatcore::InvalidArgument("export-motion: unknown motion '" + entry + "' (expected procedural:swing[:FRAMES])");
  int frames = 24;
  if (entry.size() > prefix.size()) {
    const std::string n = entry.substr(prefix.size() + 1);
    char* end = nullptr;
    const long v = std::strtol(n.c_str(), &end, 10);
    if (n.empty() || *end || v < 1 || v > 100000)
      throw gatcore::InvalidArgument("export-motion: frames must be an integer in [1, 100000], got '" + n + "'");
    frames = static_cast<int>(v);
  }
  if (std::filesystem::path(out).extension().string() != ".bvh")
    throw gatcore::InvalidArgument(out + ": the output must be a .bvh file");
  write_text_atomic(out, procedural_swing_bvh(frames));
  std::printf("%s: %d frames at 30 fps -> %s\n", entry.c_str(), frames, out.c_str());
  return 0;
}

// `gat dataset export-character ENTRY -o OUT.glb`: procedural characters as
// files, so predict-weights / deform / other tools can take them.
int export_character(int argc, char** argv) {
  std::string entry, out;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-o" && i + 1 < argc) out = argv[++i];
    else if (!a.empty() && a[0] != '-' && entry.empty()) entry = a;
    else throw gatcore::InvalidArgument("export-character: unknown or extra argument '" + a + "'");
  }
  if (entry.empty() || out.empty()) {
    usage(stderr);
    return 2;
  }
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext != ".glb" && ext != ".gltf") throw gatcore::InvalidArgument(out + ": the output must be a .glb or .gltf file");
  const Character c = load_dataset_character(entry);
  save_gltf_character(c, out);
  std::printf("%s: %lld vertices, %lld triangles, %d joints -> %s\n", entry.c_str(),
              static_cast<long long>(c.mesh.num_vertices()), static_cast<long long>(c.mesh.num_triangles()),
              c.skeleton.num_joints(), out.c_str());
  return 0;
}

}  // namespace

int cmd_dataset(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help") {
    usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  if (std::string(argv[1]) == "export-character") return export_character(argc, argv);
  if (std::string(argv[1]) == "export-motion") return export_motion(argc, argv);
  if (std::string(argv[1]) != "build")
    throw gatcore::InvalidArgument(std::string("unknown dataset action '") + argv[1] +
                                   "' (expected build, export-character or export-motion)");
  DatasetDescription s;
  s.distortion_scales = {1, 4, 16};
  std::string out;
  std::vector<std::string> inputs, motions;
  bool skip_bad = false;
  std::string test_list, validation_list;
  struct TargetArg {
    std::string character;
    FileTargetSource src;
  };
  std::vector<TargetArg> targets;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw gatcore::InvalidArgument(a + " expects a value");
      return argv[++i];
    };
    auto number = [&](double lo, double hi) {
      const std::string v = value();
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(x >= lo && x <= hi))
        throw gatcore::InvalidArgument(a + " expects a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + v + "'");
      return x;
    };
    if (a == "-o") out = value();
    else if (a == "--motion") motions.push_back(value());
    else if (a == "--random-poses") s.random_poses = static_cast<int>(number(0, 1e6));
    else if (a == "--pose-angle") s.pose_angle = static_cast<float>(number(0, 3.2));
    else if (a == "--motion-stride") s.motion_stride = static_cast<int>(number(1, 1e6));
    else if (a == "--seed") s.seed = static_cast<std::uint32_t>(number(0, 4294967295.0));
    else if (a == "--subsample") s.subsample = static_cast<std::int64_t>(number(0, 1e9));
    else if (a == "--validation") s.validation = static_cast<float>(number(0, 0.9));
    else if (a == "--test") s.test = static_cast<float>(number(0, 0.9));
    else if (a == "--dm-iterations") s.delta_mush.iterations = static_cast<int>(number(0, 10000));
    else if (a == "--dm-step") s.delta_mush.step = static_cast<float>(number(1e-6, 1));
    else if (a == "--distortion-scales") s.distortion_scales = parse_distortion_scales(value(), a);
    else if (a == "--skip-bad") skip_bad = true;
    else if (a == "--joint-limits") s.joint_limits = load_joint_limits(value());
    else if (a == "--reference") {
      s.reference = parse_reference_kind(value(), "--reference");
      if (s.reference == ReferenceKind::files)
        throw gatcore::InvalidArgument("--reference: file targets are given with --target CHARACTER TARGET MOTION");
    } else if (a == "--arap-iterations") s.arap.iterations = static_cast<int>(number(1, 10000));
    else if (a == "--arap-handle-weight") s.arap.handle_weight = static_cast<float>(number(1e-6, 1));
    else if (a == "--target") {
      TargetArg t;
      t.character = value();
      t.src.file = value();
      t.src.motion = value();
      inputs.push_back(t.character);
      targets.push_back(std::move(t));
    } else if (a == "--target-first-frame") {
      if (targets.empty()) throw gatcore::InvalidArgument("--target-first-frame follows a --target");
      targets.back().src.first_frame = number(-1e9, 1e9);
    } else if (a == "--target-animation") {
      if (targets.empty()) throw gatcore::InvalidArgument("--target-animation follows a --target");
      targets.back().src.animation = value();
    }
    else if (a == "--test-characters") test_list = value();
    else if (a == "--validation-characters") validation_list = value();
    else if (!a.empty() && a[0] == '-') throw gatcore::InvalidArgument("unknown option '" + a + "'");
    else inputs.push_back(a);
  }
  if (out.empty() || inputs.empty()) {
    usage(stderr);
    return 2;
  }
  namespace fs = std::filesystem;
  std::vector<std::string> files;
  for (const auto& in : inputs) {
    if (std::find(files.begin(), files.end(), in) != files.end()) continue;  // a --target character listed again
    if (fs::is_directory(in)) {
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(in)) {
        std::string ext = e.path().extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        if (ext == ".glb" || ext == ".gltf" || ext == ".fbx" || ext == ".dae") found.push_back(e.path().string());
      }
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  std::vector<std::string> good;
  for (const auto& f : files) {
    try {
      const Character c = load_dataset_character(f);
      std::printf("  %-60s %6lld vertices %3d joints\n", f.c_str(), static_cast<long long>(c.mesh.num_vertices()),
                  c.skeleton.num_joints());
      good.push_back(f);
    } catch (const gatcore::Error& e) {
      if (!skip_bad) throw;
      std::fprintf(stderr, "  skipped: %s\n", e.what());
    }
  }
  for (const auto& m : motions) {
    const Motion mo = load_bvh(m);
    std::printf("  %-60s %6zu frames  %3d joints\n", m.c_str(), mo.clip.frames.size(), mo.skeleton.num_joints());
  }
  DatasetDescription d = describe_dataset(good, motions, s);
  for (TargetArg& t : targets) {
    const auto it = std::find(good.begin(), good.end(), t.character);
    if (it == good.end())
      throw gatcore::InvalidArgument("--target " + t.character + ": the character did not load (see above)");
    t.src.character = static_cast<std::int32_t>(it - good.begin());
    d.targets.push_back(t.src);
  }
  if (!test_list.empty() || !validation_list.empty()) {
    // An explicit split: every listed entry must name exactly one loaded character.
    std::vector<int> role(good.size(), 0);  // 0 train, 1 validation, 2 test
    auto assign = [&](const std::string& list, int r, const char* flag) {
      std::size_t start = 0;
      while (start <= list.size()) {
        const std::size_t comma = std::min(list.find(',', start), list.size());
        const std::string item = list.substr(start, comma - start);
        start = comma + 1;
        if (item.empty()) continue;
        int found = -1;
        for (std::size_t c = 0; c < good.size(); ++c) {
          const std::string& f = good[c];
          const bool match = f == item || (f.size() > item.size() && f.compare(f.size() - item.size(), item.size(), item) == 0 &&
                                           f[f.size() - item.size() - 1] == '/');
          if (!match) continue;
          if (found >= 0)
            throw gatcore::InvalidArgument(std::string(flag) + ": '" + item + "' names both " + good[std::size_t(found)] +
                                           " and " + f);
          found = static_cast<int>(c);
        }
        if (found < 0) throw gatcore::InvalidArgument(std::string(flag) + ": '" + item + "' names no loaded character");
        if (role[std::size_t(found)] != 0)
          throw gatcore::InvalidArgument(std::string(flag) + ": '" + item + "' is already in another part");
        role[std::size_t(found)] = r;
      }
    };
    assign(validation_list, 1, "--validation-characters");
    assign(test_list, 2, "--test-characters");
    d.split = Split{};
    for (std::size_t c = 0; c < good.size(); ++c)
      (role[c] == 0 ? d.split.train : role[c] == 1 ? d.split.validation : d.split.test).push_back(static_cast<std::int32_t>(c));
  }
  // File targets are checked (vertex counts, frame map, distance to LBS)
  // before anything is written.
  for (const FileTargetSource& t : d.targets) {
    const Character file_character = load_dataset_character(d.characters[std::size_t(t.character)]);
    PreparedCharacter pc = prepare_character(file_character, d.delta_mush, {});
    const FileTargetSummary f = attach_file_targets(pc, file_character, t, out);
    std::printf("  target %s: %d frames = motion frames %g + k x %g of %s (%lld frames); distance to LBS mean %.5f, "
                "max %.5f\n", t.file.c_str(), f.frames, f.first_frame, f.step, t.motion.c_str(),
                static_cast<long long>(f.motion_frames), f.mean_to_lbs, f.max_to_lbs);
  }
  save_dataset(out, d);
  char reference[128];
  if (d.reference == ReferenceKind::arap)
    std::snprintf(reference, sizeof reference, "ARAP %d iterations, handles at weight >= %g", d.arap.iterations,
                  double(d.arap.handle_weight));
  else
    std::snprintf(reference, sizeof reference, "Delta Mush %d x %g", d.delta_mush.iterations, double(d.delta_mush.step));
  std::printf("%s: %zu characters (train %zu, validation %zu, test %zu), %zu motions, %s, %zu with file targets, "
              "random poses within %s\n", out.c_str(), d.characters.size(), d.split.train.size(),
              d.split.validation.size(), d.split.test.size(), d.motions.size(), reference, d.targets.size(),
              d.joint_limits ? ("joint limits '" + d.joint_limits->name + "'").c_str() : "+-pose-angle per joint axis");
  return 0;
}

}  // namespace gat
