// The dataset description file (JSON, through nlohmann-json).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <type_traits>
#include <cmath>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/atomic_file.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

DatasetDescription describe_dataset(std::vector<std::string> characters, std::vector<std::string> motions,
                                    const DatasetDescription& settings) {
  DatasetDescription d = settings;
  d.characters = std::move(characters);
  d.motions = std::move(motions);
  d.split = {};
  validate_dataset(d, "dataset");
  d.split = split_by_character(static_cast<std::int32_t>(d.characters.size()), d.validation, d.test, d.seed);
  validate_dataset(d, "dataset");
  return d;
}

void validate_dataset(const DatasetDescription& d, const std::string& where) {
  const DatasetLimits L;
  auto range = [&](const char* field, double v, double lo, double hi) {
    GATCORE_CHECK(std::isfinite(v) && v >= lo && v <= hi, where, ": field \"", field, "\" = ", v, " is out of range [",
                  lo, ", ", hi, "]");
  };
  GATCORE_CHECK(!d.characters.empty(), where, ": no characters");
  range("random_poses", d.random_poses, 0, L.max_random_poses);
  range("pose_angle", d.pose_angle, 0, L.max_pose_angle);
  range("motion_stride", d.motion_stride, 1, L.max_motion_stride);
  range("subsample", double(d.subsample), 0, L.max_subsample);
  range("validation", d.validation, 0, L.max_fraction);
  range("test", d.test, 0, L.max_fraction);
  range("validation + test", double(d.validation) + double(d.test), 0, L.max_fraction);
  range("reference_deformer.iterations", d.delta_mush.iterations, 0, L.max_dm_iterations);
  range("reference_deformer.step", d.delta_mush.step, L.min_dm_step, 1);
  check_distortion_scales(d.distortion_scales, where + ": field \"distortion_scales\"");
  const auto n = static_cast<std::int64_t>(d.characters.size());
  std::vector<const char*> role(static_cast<std::size_t>(n), nullptr);
  for (const auto& [name, v] : {std::pair<const char*, const std::vector<std::int32_t>*>{"train", &d.split.train},
                                {"validation", &d.split.validation},
                                {"test", &d.split.test}})
    for (std::int32_t c : *v) {
      GATCORE_CHECK(c >= 0 && c < n, where, ": split \"", name, "\" names character ", c, " of ", n);
      GATCORE_CHECK(!role[std::size_t(c)], where, ": character ", c, " is in split \"", role[std::size_t(c)] ? role[std::size_t(c)] : "",
                    "\" and again in \"", name, "\"");
      role[std::size_t(c)] = name;
    }
  range("augment.copies", d.augment.copies, 0, kMaxAugmentCopies);
  // A variant trains only if its source is not held out.
  std::vector<std::string> held_out;
  for (std::int64_t c = 0; c < n; ++c) {
    const std::string& e = d.characters[std::size_t(c)];
    if (is_augment_entry(e)) (void)parse_augment_entry(e);  // throws for a malformed one
    if (role[std::size_t(c)] && std::string(role[std::size_t(c)]) != "train") held_out.push_back(augment_source(e));
  }
  for (std::int32_t c : d.split.train) {
    const std::string src = augment_source(d.characters[std::size_t(c)]);
    GATCORE_CHECK(std::find(held_out.begin(), held_out.end(), src) == held_out.end(), where, ": character ", c, " (",
                  d.characters[std::size_t(c)], ") trains, but ", src, " (its source, or a variant of it) is held out");
  }
}

std::string augment_source(const std::string& entry) {
  return is_augment_entry(entry) ? parse_augment_entry(entry).source : entry;
}

std::string dataset_character_name(const std::string& entry) {
  if (is_augment_entry(entry)) {
    const AugmentEntry a = parse_augment_entry(entry);
    return dataset_character_name(a.source) + "~aug" + std::to_string(a.seed);
  }
  if (entry.rfind("procedural:", 0) == 0) return entry;
  const std::filesystem::path f(entry);
  const std::string dir = f.parent_path().filename().string();
  return (dir.empty() ? "" : dir + "/") + f.stem().string();
}

void add_augmented_variants(DatasetDescription& d) {
  validate_dataset(d, "dataset");
  if (d.augment.kinds.empty() || d.augment.copies == 0) return;
  const auto n = static_cast<std::int32_t>(d.characters.size());
  std::vector<std::vector<std::int32_t>*> part(std::size_t(n), nullptr);
  for (auto* v : {&d.split.train, &d.split.validation, &d.split.test})
    for (std::int32_t c : *v) part[std::size_t(c)] = v;
  const std::size_t K = d.augment.kinds.size();
  for (std::int32_t c = 0; c < n; ++c) {
    if (is_augment_entry(d.characters[std::size_t(c)])) continue;
    for (int copy = 0; copy < d.augment.copies; ++copy) {
      // Seeded by (seed, source entry, copy), not by position, so the same
      // character gets the same variants in any dataset.
      std::uint32_t h = 2166136261u;  // FNV-1a: the same on every platform
      for (unsigned char ch : d.characters[std::size_t(c)]) h = (h ^ ch) * 16777619u;
      std::seed_seq seq{d.augment.seed, h, static_cast<std::uint32_t>(copy)};
      std::mt19937 rng(seq);
      AugmentEntry e;
      e.source = d.characters[std::size_t(c)];
      e.seed = rng();
      // A non-empty subset of the kinds, each with probability 1/2.
      while (e.kinds.empty())
        for (std::size_t k = 0; k < K; ++k)
          if (K == 1 || rng() % 2) e.kinds.push_back(d.augment.kinds[k]);
      const auto index = static_cast<std::int32_t>(d.characters.size());
      d.characters.push_back(augment_entry(e));
      if (part[std::size_t(c)]) part[std::size_t(c)]->push_back(index);
    }
  }
  validate_dataset(d, "dataset");
}

namespace {

namespace fs = std::filesystem;
bool is_file_entry(const std::string& e) { return e.rfind("procedural:", 0) != 0 && !is_augment_entry(e); }

// File entries are stored relative to the dataset file's directory.
// Each path of an entry: a motion "SKELETON.asf:MOTION.amc" (load_motion) names two.
template <class F>
std::string each_path(const std::string& e, F&& f) {
  std::string low = e;
  for (char& c : low) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::size_t cut = low.find(".asf:");
  if (cut == std::string::npos) return f(e);
  return f(e.substr(0, cut + 4)) + ":" + f(e.substr(cut + 5));
}

std::vector<std::string> resolve(const std::vector<std::string>& entries, const std::string& dataset);
std::vector<std::string> relative_to(const std::vector<std::string>& entries, const std::string& dataset);

// A variant's source is stored like any other entry.
std::string map_variant(const std::string& e, const std::string& dataset, bool relative) {
  AugmentEntry a = parse_augment_entry(e);
  a.source = (relative ? relative_to({a.source}, dataset) : resolve({a.source}, dataset))[0];
  return augment_entry(a);
}

std::vector<std::string> relative_to(const std::vector<std::string>& entries, const std::string& dataset) {
  const fs::path base = fs::absolute(fs::path(dataset)).parent_path();
  std::vector<std::string> out;
  for (const auto& e : entries)
    out.push_back(is_augment_entry(e) ? map_variant(e, dataset, true) : is_file_entry(e) ? each_path(e, [&](const std::string& p) {
      return fs::absolute(p).lexically_normal().lexically_relative(base).generic_string();
    })
                                   : e);
  return out;
}

std::vector<std::string> resolve(const std::vector<std::string>& entries, const std::string& dataset) {
  const fs::path base = fs::absolute(fs::path(dataset)).parent_path();
  std::vector<std::string> out;
  for (const auto& e : entries)
    out.push_back(is_augment_entry(e) ? map_variant(e, dataset, false) : is_file_entry(e) ? each_path(e, [&](const std::string& p) {
      return fs::path(p).is_relative() ? (base / p).lexically_normal().string() : p;
    })
                                   : e);
  return out;
}

}  // namespace

void save_dataset(const std::string& path, const DatasetDescription& d) {
  validate_dataset(d, path);
  nlohmann::json j;
  j["format"] = "gatcore-dataset";
  j["version"] = 1;
  j["characters"] = relative_to(d.characters, path);  // relative to this file
  j["motions"] = relative_to(d.motions, path);
  j["random_poses"] = d.random_poses;
  j["pose_angle"] = d.pose_angle;
  if (d.joint_limits) j["joint_limits"] = nlohmann::json::parse(joint_limits_json(*d.joint_limits));
  j["motion_stride"] = d.motion_stride;
  j["seed"] = d.seed;
  if (d.reference == ReferenceKind::arap)
    j["reference_deformer"] = {{"name", "arap"}, {"iterations", d.arap.iterations}, {"handle_weight", d.arap.handle_weight}};
  else
    j["reference_deformer"] = {{"name", "delta_mush"}, {"iterations", d.delta_mush.iterations}, {"step", d.delta_mush.step}};
  if (!d.targets.empty()) {
    nlohmann::json targets = nlohmann::json::array();
    for (const FileTargetSource& t : d.targets) {
      // Each file (and a BVH motion) relative to this file, like the characters.
      std::vector<std::string> files;
      std::stringstream ss(t.file);
      for (std::string f; std::getline(ss, f, ',');)
        if (!f.empty()) files.push_back(f);
      std::string joined;
      for (const std::string& f : relative_to(files, path)) joined += (joined.empty() ? "" : ",") + f;
      const bool clip = t.motion == "clip" || t.motion.rfind("clip:", 0) == 0;
      nlohmann::json tj = {{"character", t.character}, {"file", joined},
                           {"motion", clip ? t.motion : relative_to({t.motion}, path)[0]}};
      if (!t.animation.empty()) tj["animation"] = t.animation;
      if (t.first_frame) tj["first_frame"] = *t.first_frame;
      targets.push_back(tj);
    }
    j["targets"] = targets;
  }
  j["subsample"] = d.subsample;
  j["distortion_scales"] = d.distortion_scales;
  j["validation"] = d.validation;
  j["test"] = d.test;
  j["split"] = {{"train", d.split.train}, {"validation", d.split.validation}, {"test", d.split.test}};
  if (!d.augment.kinds.empty()) {
    std::vector<std::string> kinds;
    for (AugmentKind k : d.augment.kinds) kinds.emplace_back(augment_kind_name(k));
    j["augment"] = {{"kinds", kinds}, {"copies", d.augment.copies}, {"seed", d.augment.seed}};
  }
  write_file_atomic(path, j.dump(2) + "\n");
}

namespace {

// A JSON number read into T only after it is known to be finite, within
// [lo, hi] and (for integer T) whole: nlohmann's get<int>() of 1e20 is an
// out-of-range float->int conversion (undefined behaviour).
template <class T>
T json_number(const nlohmann::json& j, const std::string& field, double lo, double hi, const std::string& path) {
  GATCORE_CHECK(j.is_number(), path, ": field \"", field, "\" must be a number, got ", j.dump());
  const double v = j.get<double>();
  GATCORE_CHECK(std::isfinite(v) && v >= lo && v <= hi, path, ": field \"", field, "\" = ", j.dump(),
                " is out of range [", lo, ", ", hi, "]");
  if constexpr (std::is_integral_v<T>)
    GATCORE_CHECK(v == std::floor(v), path, ": field \"", field, "\" = ", j.dump(), " is not a whole number");
  return static_cast<T>(v);
}

std::vector<std::int32_t> json_indices(const nlohmann::json& j, const std::string& field, const std::string& path) {
  GATCORE_CHECK(j.is_array(), path, ": field \"", field, "\" must be an array");
  std::vector<std::int32_t> out;
  for (const auto& x : j) out.push_back(json_number<std::int32_t>(x, field, 0, 2147483647.0, path));
  return out;
}

}  // namespace

DatasetDescription load_dataset(const std::string& path) {
  std::ifstream f(path);
  GATCORE_CHECK(f.good(), path, ": cannot open file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    throw InvalidArgument(detail::cat(path, ": not a JSON dataset description: ", e.what()));
  }
  try {
    GATCORE_CHECK(j.value("format", "") == "gatcore-dataset", path, ": not a gatcore dataset (\"format\" is not \"gatcore-dataset\")");
    GATCORE_CHECK(j.contains("version") && j.at("version").is_number() && j.at("version") == 1, path,
                  ": unsupported dataset version ", j.contains("version") ? j.at("version").dump() : "(none)");
    DatasetDescription d;
    d.characters = resolve(j.at("characters").get<std::vector<std::string>>(), path);
    d.motions = resolve(j.at("motions").get<std::vector<std::string>>(), path);
    const DatasetLimits L;
    d.random_poses = json_number<int>(j.at("random_poses"), "random_poses", 0, L.max_random_poses, path);
    d.pose_angle = json_number<float>(j.at("pose_angle"), "pose_angle", 0, L.max_pose_angle, path);
    if (j.contains("joint_limits"))
      d.joint_limits = parse_joint_limits(j.at("joint_limits").dump(), path + ": field \"joint_limits\"");
    d.motion_stride = json_number<int>(j.at("motion_stride"), "motion_stride", 1, L.max_motion_stride, path);
    d.seed = json_number<std::uint32_t>(j.at("seed"), "seed", 0, 4294967295.0, path);
    const auto& rd = j.at("reference_deformer");
    d.reference = parse_reference_kind(rd.at("name").get<std::string>(), path + ": field \"reference_deformer\"");
    GATCORE_CHECK(d.reference != ReferenceKind::files, path,
                  ": \"reference_deformer\" is a built-in deformer (delta_mush or arap); file targets go in \"targets\"");
    if (d.reference == ReferenceKind::arap) {
      d.arap.iterations =
          json_number<int>(rd.at("iterations"), "reference_deformer.iterations", 1, L.max_dm_iterations, path);
      d.arap.handle_weight =
          json_number<float>(rd.at("handle_weight"), "reference_deformer.handle_weight", 0, 1e6, path);
    } else {
      d.delta_mush.iterations =
          json_number<int>(rd.at("iterations"), "reference_deformer.iterations", 0, L.max_dm_iterations, path);
      d.delta_mush.step = json_number<float>(rd.at("step"), "reference_deformer.step", L.min_dm_step, 1, path);
    }
    if (j.contains("targets")) {
      GATCORE_CHECK(j.at("targets").is_array(), path, ": field \"targets\" must be an array");
      for (const auto& tj : j.at("targets")) {
        FileTargetSource t;
        t.character = json_number<std::int32_t>(tj.at("character"), "targets.character", 0, 1e9, path);
        std::vector<std::string> files;
        std::stringstream ss(tj.at("file").get<std::string>());
        for (std::string f; std::getline(ss, f, ',');)
          if (!f.empty()) files.push_back(f);
        GATCORE_CHECK(!files.empty(), path, ": a target has no file");
        for (const std::string& f : resolve(files, path)) t.file += (t.file.empty() ? "" : ",") + f;
        const std::string m = tj.at("motion").get<std::string>();
        t.motion = m == "clip" || m.rfind("clip:", 0) == 0 ? m : resolve({m}, path)[0];
        t.animation = tj.value("animation", "");
        if (tj.contains("first_frame"))
          t.first_frame = json_number<double>(tj.at("first_frame"), "targets.first_frame", -1e9, 1e9, path);
        d.targets.push_back(std::move(t));
      }
    }
    d.subsample = json_number<std::int64_t>(j.at("subsample"), "subsample", 0, L.max_subsample, path);
    // Absent in datasets written before the field: the paper's features only.
    if (j.contains("distortion_scales")) {
      GATCORE_CHECK(j.at("distortion_scales").is_array(), path, ": field \"distortion_scales\" must be an array");
      for (const auto& x : j.at("distortion_scales"))
        d.distortion_scales.push_back(json_number<int>(x, "distortion_scales", -1e6, 1e6, path));
      check_distortion_scales(d.distortion_scales, path + ": field \"distortion_scales\"");
    }
    d.validation = json_number<float>(j.at("validation"), "validation", 0, L.max_fraction, path);
    d.test = json_number<float>(j.at("test"), "test", 0, L.max_fraction, path);
    d.split.train = json_indices(j.at("split").at("train"), "split.train", path);
    d.split.validation = json_indices(j.at("split").at("validation"), "split.validation", path);
    d.split.test = json_indices(j.at("split").at("test"), "split.test", path);
    if (j.contains("augment")) {
      const auto& a = j.at("augment");
      GATCORE_CHECK(a.is_object(), path, ": field \"augment\" must be an object");
      std::string kinds;
      GATCORE_CHECK(a.at("kinds").is_array(), path, ": field \"augment.kinds\" must be an array of names");
      for (const auto& k : a.at("kinds")) {
        if (!kinds.empty()) kinds += ',';
        kinds += k.get<std::string>();
      }
      d.augment.kinds = parse_augment_kinds(kinds, path + ": field \"augment.kinds\"");
      d.augment.copies = json_number<int>(a.at("copies"), "augment.copies", 0, kMaxAugmentCopies, path);
      d.augment.seed = json_number<std::uint32_t>(a.at("seed"), "augment.seed", 0, 4294967295.0, path);
    }
    const auto n = static_cast<std::int32_t>(d.characters.size());
    std::vector<char> has_target(std::size_t(n), 0);
    for (const FileTargetSource& t : d.targets) {
      GATCORE_CHECK(t.character >= 0 && t.character < n, path, ": a target names character ", t.character, " of ", n);
      GATCORE_CHECK(!has_target[std::size_t(t.character)], path, ": character ", t.character, " has two targets");
      has_target[std::size_t(t.character)] = 1;
    }
    // The same checks as `gat dataset build` (describe_dataset).
    validate_dataset(d, path);
    return d;
  } catch (const nlohmann::json::exception& e) {
    throw InvalidArgument(detail::cat(path, ": bad dataset description: ", e.what()));
  }
}

Character load_dataset_character(const std::string& entry) {
  if (is_augment_entry(entry)) {
    const AugmentEntry a = parse_augment_entry(entry);
    return augment_character(load_dataset_character(a.source), a.kinds, a.seed);
  }
  const std::string pre = "procedural:";
  if (entry.rfind(pre, 0) == 0) {
    const std::string rest = entry.substr(pre.size());
    const std::size_t colon = rest.find(':');
    const std::string kind = rest.substr(0, colon);
    GATCORE_CHECK((kind == "humanoid" || kind == "creature") && colon != std::string::npos && colon + 1 < rest.size(),
                  "dataset character '", entry, "': expected procedural:humanoid:SEED or procedural:creature:SEED");
    ProceduralOptions o;
    o.kind = kind == "humanoid" ? ProceduralKind::humanoid : ProceduralKind::creature;
    char* end = nullptr;
    o.seed = static_cast<std::uint32_t>(std::strtoul(rest.c_str() + colon + 1, &end, 10));
    GATCORE_CHECK(end && *end == '\0', "dataset character '", entry, "': the seed is not a number");
    return procedural_character(o);
  }
  return load_character(entry);
}

std::vector<SampleTask> dataset_tasks(const DatasetDescription& d, const std::vector<PreparedCharacter>& prepared,
                                      const std::vector<Motion>& motions, std::span<const std::int32_t> characters,
                                      int epoch) {
  std::vector<SampleTask> tasks;
  std::mt19937 rng(d.seed * 7919u + static_cast<std::uint32_t>(epoch));
  for (std::int32_t c : characters) {
    GATCORE_CHECK(c >= 0 && c < static_cast<std::int32_t>(prepared.size()), "dataset_tasks: character ", c, " of ",
                  prepared.size());
    const PreparedCharacter& pc = prepared[c];
    const std::int64_t n = pc.character.mesh.num_vertices();
    const std::int64_t count = d.subsample <= 0 || d.subsample >= n ? n : d.subsample;
    auto add = [&](Pose pose, std::int32_t index) {
      SampleTask t;
      t.character = c;
      t.pose_index = index;
      t.pose = std::move(pose);
      t.count = count;
      t.first = count < n ? static_cast<std::int64_t>(rng() % static_cast<std::uint32_t>(n - count + 1)) : 0;
      tasks.push_back(std::move(t));
    };
    // File targets: their frames only, every motion_stride-th, from a phase
    // that moves with the epoch (so `stride` epochs see every frame).
    if (const std::int32_t F = pc.reference ? pc.reference->num_frames() : 0; F > 0) {
      GATCORE_CHECK(static_cast<std::int32_t>(pc.target_poses.size()) == F, "dataset_tasks: character ", c, " has ",
                    F, " target frames but ", pc.target_poses.size(), " poses");
      const std::int32_t stride = std::min(d.motion_stride, F);
      std::int32_t index = 0;
      for (std::int32_t k = epoch % stride; k < F; k += stride) {
        add(pc.target_poses[std::size_t(k)], index++);
        tasks.back().target_frame = k;
      }
      continue;
    }
    const auto limits = d.joint_limits ? d.joint_limits->limits_for(pc.character.skeleton)
                                       : uniform_limits(pc.character.skeleton, d.pose_angle);
    for (int p = 0; p < d.random_poses; ++p) add(random_pose(pc.character.skeleton, pc.rest, limits, rng), p);
    std::int32_t index = d.random_poses;
    for (const Motion& m : motions) {
      RetargetOptions ro;
      ro.target_name = pc.character.name;
      const Clip clip = retarget(m, pc.character.skeleton, mat4_identity(), ro);
      for (std::size_t f = 0; f < clip.frames.size(); f += static_cast<std::size_t>(d.motion_stride))
        add(clip.frames[f], index++);
    }
  }
  return tasks;
}

}  // namespace gatcore::character
