// `gat dataset build -o DATASET.json [options] CHARACTER|DIR ... [--motion M.bvh ...]`:
// checks that every character (and motion) loads, then writes the dataset
// description the trainer streams samples from (see dataset.hpp).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/file_targets.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "progress.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace gat {

namespace {

// `gat dataset export-motion procedural:swing[:N] -o OUT.bvh`: a motion for
// the examples and tests that needs no downloaded data.
int export_motion(const std::string& entry, const std::string& out) {
  const std::string prefix = "procedural:swing";
  if (entry.compare(0, prefix.size(), prefix) != 0 || (entry.size() > prefix.size() && entry[prefix.size()] != ':'))
    throw gatcore::InvalidArgument("export-motion: unknown motion '" + entry + "' (expected procedural:swing[:FRAMES])");
  int frames = 24;
  if (entry.size() > prefix.size()) {
    frames = static_cast<int>(parse_int("export-motion: frames", entry.substr(prefix.size() + 1), 1, 100000));
  }
  if (std::filesystem::path(out).extension().string() != ".bvh")
    throw gatcore::InvalidArgument(out + ": the output must be a .bvh file");
  write_text_atomic(out, procedural_swing_bvh(frames));
  std::printf("%s: %d frames at 30 fps -> %s\n", entry.c_str(), frames, out.c_str());
  return 0;
}

// `gat dataset export-character ENTRY -o OUT.glb`: procedural characters as
// files, so predict-weights / deform / other tools can take them.
int export_character(const std::string& entry, const std::string& out) {
  const std::string ext = std::filesystem::path(out).extension().string();
  if (ext != ".glb" && ext != ".gltf") throw gatcore::InvalidArgument(out + ": the output must be a .glb or .gltf file");
  const Character c = load_dataset_character(entry);
  save_gltf_character(c, out);
  std::printf("%s: %lld vertices, %lld triangles, %d joints -> %s\n", entry.c_str(),
              static_cast<long long>(c.mesh.num_vertices()), static_cast<long long>(c.mesh.num_triangles()),
              c.skeleton.num_joints(), out.c_str());
  return 0;
}

struct BuildArgs {
  DatasetDescription s;
  std::string out, test_list, validation_list, joint_limits, distortion_scales = "1,4,16", reference = "delta_mush";
  std::string augment;
  std::vector<std::string> inputs, motions;
  bool skip_bad = false, quiet = false;
  // --target CHARACTER TARGET MOTION (3 values per occurrence), and the
  // --target-first-frame / --target-animation that follow one (parse order).
  std::vector<std::string> target_values, target_animations;
  std::vector<double> target_first_frames;
  struct TargetArg {
    std::string character;
    FileTargetSource src;
  };
  std::vector<TargetArg> targets;
};

// The --target triples with the --target-first-frame / --target-animation
// given after each (CLI11 keeps each option's values apart; the parse order
// says which --target they follow).
void collect_targets(CLI::App& cmd, BuildArgs& b) {
  std::size_t first = 0, anim = 0, target_entries = 0, seen = 0;
  // CLI11 (2.1) lists an option in parse_order() once per value it took:
  // 3 entries per --target.
  for (const CLI::Option* o : cmd.parse_order()) target_entries += o->get_name() == "--target";
  const std::size_t occurrences = b.target_values.size() / 3;
  const std::size_t per = occurrences ? std::max<std::size_t>(1, target_entries / occurrences) : 1;
  for (const CLI::Option* o : cmd.parse_order()) {
    const std::string name = o->get_name();
    if (name == "--target") {
      if (seen++ % per) continue;  // the same occurrence's next value
      const std::size_t t = b.targets.size();
      BuildArgs::TargetArg ta;
      ta.character = b.target_values.at(3 * t);
      ta.src.file = b.target_values.at(3 * t + 1);
      ta.src.motion = b.target_values.at(3 * t + 2);
      b.targets.push_back(std::move(ta));
    } else if (name == "--target-first-frame") {
      if (b.targets.empty()) throw gatcore::InvalidArgument("--target-first-frame follows a --target");
      b.targets.back().src.first_frame = b.target_first_frames.at(first++);
    } else if (name == "--target-animation") {
      if (b.targets.empty()) throw gatcore::InvalidArgument("--target-animation follows a --target");
      b.targets.back().src.animation = b.target_animations.at(anim++);
    }
  }
}

int build(BuildArgs& a) {
  DatasetDescription& s = a.s;
  s.distortion_scales = parse_distortion_scales(a.distortion_scales, "--distortion-scales");
  if (!a.joint_limits.empty()) s.joint_limits = load_joint_limits(a.joint_limits);
  s.reference = parse_reference_kind(a.reference, "--reference");
  if (!a.augment.empty()) s.augment.kinds = parse_augment_kinds(a.augment, "--augment");
  if (s.reference == ReferenceKind::files)
    throw gatcore::InvalidArgument("--reference: file targets are given with --target CHARACTER TARGET MOTION");
  const std::string out = a.out, test_list = a.test_list, validation_list = a.validation_list;
  std::vector<std::string> inputs = a.inputs;
  for (const auto& t : a.targets) inputs.push_back(t.character);
  const std::vector<std::string>& motions = a.motions;
  const bool skip_bad = a.skip_bad;
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
  gat::Progress progress("checking characters", std::int64_t(files.size()), "characters", a.quiet);
  for (const auto& f : files) {
    progress.update(std::int64_t(&f - files.data()), f);
    try {
      const Character c = load_dataset_character(f);
      if (!a.quiet) progress.finish();
      if (!a.quiet) std::printf("  %-60s %6lld vertices %3d joints\n", f.c_str(), static_cast<long long>(c.mesh.num_vertices()),
                  c.skeleton.num_joints());
      good.push_back(f);
    } catch (const gatcore::Error& e) {
      if (!skip_bad) throw;
      progress.finish();
      std::fprintf(stderr, "  skipped: %s\n", e.what());
    }
  }
  progress.finish();
  for (const auto& m : motions) {
    const Motion mo = load_motion(m);
    if (!a.quiet) std::printf("  %-60s %6zu frames  %3d joints\n", m.c_str(), mo.clip.frames.size(), mo.skeleton.num_joints());
  }
  DatasetDescription d = describe_dataset(good, motions, s);
  for (const BuildArgs::TargetArg& t : a.targets) {
    const auto it = std::find(good.begin(), good.end(), t.character);
    if (it == good.end())
      throw gatcore::InvalidArgument("--target " + t.character + ": the character did not load (see above)");
    FileTargetSource src = t.src;
    src.character = static_cast<std::int32_t>(it - good.begin());
    d.targets.push_back(src);
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
  add_augmented_variants(d);  // after the split: each variant joins its source's part
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

}  // namespace

Runner setup_dataset(CLI::App& gat) {
  CLI::App& c = add_command(gat, "dataset",
                            "build a dataset description (characters, motions, split, reference deformer); export "
                            "procedural characters and motions");
  c.require_subcommand(1);
  auto b = std::make_shared<BuildArgs>();
  b->s.distortion_scales = {1, 4, 16};
  CLI::App& build_cmd = add_command(c, "build", "check that every character and motion loads, write DATASET.json");
  auto& s = b->s;
  add_out(build_cmd, b->out, "the dataset description to write (DATASET.json)")->required();
  build_cmd.add_option("CHARACTER", b->inputs,
                       ".glb/.gltf/.fbx/.dae file, a directory of them, or procedural:humanoid:SEED / "
                       "procedural:creature:SEED (a --target's character need not be listed again)")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  add_repeatable(build_cmd, "--motion", b->motions, "a BVH motion, retargeted onto every character");
  build_cmd.add_option("--random-poses", s.random_poses, "random poses per character and epoch")
      ->check(int_in(0, 1000000))->capture_default_str();
  build_cmd.add_option("--pose-angle", s.pose_angle, "random joint angles within +-RAD per axis")
      ->check(number_in(0, 3.2))->capture_default_str();
  build_cmd.add_option("--motion-stride", s.motion_stride, "every K-th motion frame")
      ->check(int_in(1, 1000000))->capture_default_str();
  build_cmd.add_option("--seed", s.seed, "split, poses and windows")->check(int_in(0, 4294967295LL))->capture_default_str();
  build_cmd.add_option("--subsample", s.subsample, "DenseGATs: consecutive vertices per sample (0: whole mesh)")
      ->check(int_in(0, 1000000000))->capture_default_str();
  build_cmd.add_option("--validation", s.validation,
                       "fraction of characters that validate (at least one when the fraction is above 0 and there "
                       "are 3 or more characters)")
      ->check(number_in(0, 0.9))->capture_default_str();
  build_cmd.add_option("--test", s.test, "fraction of characters held out for testing (as --validation)")
      ->check(number_in(0, 0.9))->capture_default_str();
  build_cmd.add_option("--dm-iterations", s.delta_mush.iterations, "the reference Delta Mush's smoothing iterations")
      ->check(int_in(0, 10000))->capture_default_str();
  build_cmd.add_option("--dm-step", s.delta_mush.step, "the reference Delta Mush's smoothing step")
      ->check(number_in(1e-6, 1))->capture_default_str();
  build_cmd.add_option("--reference", b->reference,
                       "the built-in reference deformer the targets come from: delta_mush, or arap (as-rigid-as-"
                       "possible on LBS, include/gatcore/character/deform/arap.hpp)")
      ->check(one_of({"delta_mush", "arap"}))->capture_default_str();
  build_cmd.add_option("--arap-iterations", s.arap.iterations, "ARAP's local/global iterations")
      ->check(int_in(1, 10000))->capture_default_str();
  build_cmd.add_option("--arap-handle-weight", s.arap.handle_weight,
                       "ARAP: vertices whose dominant weight is at least W are handles (follow LBS)")
      ->check(number_in(1e-6, 1))->capture_default_str();
  build_cmd.add_option("--target", b->target_values,
                       "CHARACTER TARGET MOTION: the character's own per-frame targets instead: TARGET a .pc2 point "
                       "cache (or comma-separated .pc2, one per mesh, in the file's order) or a glTF with a "
                       "morph-target animation (what gat deform writes); MOTION the BVH that drove it, or clip:NAME "
                       "(the character file's own animation). Target frame k is motion frame FIRST + k * (the .pc2 "
                       "sample rate); FIRST: the .pc2 start frame, 0 for a glTF, or --target-first-frame F after the "
                       "--target (give it for gat deform's caches: their header holds the scene frame, --start-frame, "
                       "not the motion's). Vertex and frame counts are checked; the character trains and evaluates on its "
                       "target frames only (every --motion-stride-th per epoch)")
      ->expected(3)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  build_cmd.add_option("--target-first-frame", b->target_first_frames,
                       "F: the motion frame of the preceding --target's first target frame")
      ->check(number_in(-1e9, 1e9))->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  build_cmd.add_option("--target-animation", b->target_animations,
                       "NAME: the preceding --target glTF's morph animation (default 'deform')")
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  build_cmd.add_flag("--skip-bad", b->skip_bad, "skip unreadable characters (each named on stderr)");
  build_cmd.add_option("--distortion-scales", b->distortion_scales,
                       "K1,K2,... DenseGATs input columns: the skinning distortion of the mesh's detail coordinates "
                       "at these smoothing scales (include/gatcore/character/deform/detail_distortion.hpp); 'none' = the "
                       "paper's features only")
      ->capture_default_str();
  build_cmd.add_option("--joint-limits", b->joint_limits,
                       "FILE|humanoid: per-joint random-pose limits (JSON table, see "
                       "include/gatcore/character/rig/joint_limits.hpp; 'humanoid' = the built-in table); recorded in the "
                       "dataset; without it every joint axis gets +-pose-angle");
  build_cmd.add_option("--test-characters", b->test_list,
                       "A,B,... an explicit split instead of the seeded one: each entry names one character by the "
                       "end of its path (e.g. modular_men/Punk.glb); the rest train");
  build_cmd.add_option("--validation-characters", b->validation_list, "C,D,... as --test-characters");
  CLI::Option* aug = build_cmd.add_option("--augment", b->augment, "KIND,...|all: augmented variants of every character "
                                          "(rigid, decimate, remesh, rename, split, merge, helpers, twist, chains, rotate, scale, z-up; "
                                          "include/gatcore/character/data/augment.hpp), each in its source's split part");
  build_cmd.add_option("--augment-copies", s.augment.copies, "variants per character")->check(int_in(0, kMaxAugmentCopies))->needs(aug)->capture_default_str();
  build_cmd.add_option("--augment-seed", s.augment.seed, "seed of the variants' kinds and parameters")->check(int_in(0, 4294967295LL))->needs(aug);
  build_cmd.add_flag("-q,--quiet", b->quiet, "no progress line and no per-character lines: only the summary");

  auto entry = std::make_shared<std::string>(), out = std::make_shared<std::string>();
  CLI::App& xc = add_command(c, "export-character", "write a dataset character (e.g. procedural:humanoid:5) as a "
                                                    "skinned glTF file");
  xc.add_option("CHARACTER", *entry, "a dataset entry: a file or procedural:humanoid:SEED / procedural:creature:SEED")
      ->required();
  add_out(xc, *out, "the .glb / .gltf to write")->required();
  CLI::App& xm = add_command(c, "export-motion", "write the built-in procedural swing motion (CMU joint names, 30 "
                                                 "fps, default 24 frames) as BVH");
  xm.add_option("MOTION", *entry, "procedural:swing[:FRAMES]")->required();
  add_out(xm, *out, "the .bvh to write")->required();
  return [b, entry, out, &build_cmd, &xc] {
    if (build_cmd.parsed()) {
      collect_targets(build_cmd, *b);
      if (b->inputs.empty() && b->targets.empty())
        throw CLI::RequiredError("CHARACTER");  // (a --target stands in for it)
      return build(*b);
    }
    if (xc.parsed()) return export_character(*entry, *out);
    return export_motion(*entry, *out);
  };
}

}  // namespace gat
