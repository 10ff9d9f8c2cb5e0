// The dataset description file (JSON, through nlohmann-json).
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <nlohmann/json.hpp>

#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

DatasetDescription describe_dataset(std::vector<std::string> characters, std::vector<std::string> motions,
                                    const DatasetDescription& settings) {
  DatasetDescription d = settings;
  d.characters = std::move(characters);
  d.motions = std::move(motions);
  GATCORE_CHECK(!d.characters.empty(), "dataset: no characters");
  GATCORE_CHECK(d.random_poses >= 0 && d.motion_stride >= 1 && d.pose_angle >= 0.0f, "dataset: random_poses ",
                d.random_poses, ", motion_stride ", d.motion_stride, ", pose_angle ", d.pose_angle, " out of range");
  d.split = split_by_character(static_cast<std::int32_t>(d.characters.size()), d.validation, d.test, d.seed);
  return d;
}

namespace {

namespace fs = std::filesystem;
bool is_file_entry(const std::string& e) { return e.rfind("procedural:", 0) != 0; }

// File entries are stored relative to the dataset file's directory.
std::vector<std::string> relative_to(const std::vector<std::string>& entries, const std::string& dataset) {
  const fs::path base = fs::absolute(fs::path(dataset)).parent_path();
  std::vector<std::string> out;
  for (const auto& e : entries)
    out.push_back(is_file_entry(e) ? fs::absolute(e).lexically_normal().lexically_relative(base).generic_string() : e);
  return out;
}

std::vector<std::string> resolve(const std::vector<std::string>& entries, const std::string& dataset) {
  const fs::path base = fs::absolute(fs::path(dataset)).parent_path();
  std::vector<std::string> out;
  for (const auto& e : entries)
    out.push_back(is_file_entry(e) && fs::path(e).is_relative() ? (base / e).lexically_normal().string() : e);
  return out;
}

}  // namespace

void save_dataset(const std::string& path, const DatasetDescription& d) {
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
  // Atomic: a temporary file beside the target, renamed over it.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    GATCORE_CHECK(f.good(), path, ": cannot write the file (", tmp, ")");
    f << j.dump(2) << "\n";
    f.flush();
    GATCORE_CHECK(f.good(), path, ": cannot write the file (", tmp, ")");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  GATCORE_CHECK(!ec, path, ": cannot replace the file: ", ec.message());
}

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
    GATCORE_CHECK(j.value("version", 0) == 1, path, ": unsupported dataset version ", j.value("version", 0));
    DatasetDescription d;
    d.characters = resolve(j.at("characters").get<std::vector<std::string>>(), path);
    d.motions = resolve(j.at("motions").get<std::vector<std::string>>(), path);
    d.random_poses = j.at("random_poses").get<int>();
    d.pose_angle = j.at("pose_angle").get<float>();
    if (j.contains("joint_limits"))
      d.joint_limits = parse_joint_limits(j.at("joint_limits").dump(), path + ": field \"joint_limits\"");
    d.motion_stride = j.at("motion_stride").get<int>();
    d.seed = j.at("seed").get<std::uint32_t>();
    const auto& rd = j.at("reference_deformer");
    d.reference = parse_reference_kind(rd.at("name").get<std::string>(), path + ": field \"reference_deformer\"");
    GATCORE_CHECK(d.reference != ReferenceKind::files, path,
                  ": \"reference_deformer\" is a built-in deformer (delta_mush or arap); file targets go in \"targets\"");
    if (d.reference == ReferenceKind::arap) {
      d.arap.iterations = rd.at("iterations").get<int>();
      d.arap.handle_weight = rd.at("handle_weight").get<float>();
    } else {
      d.delta_mush.iterations = rd.at("iterations").get<int>();
      d.delta_mush.step = rd.at("step").get<float>();
    }
    if (j.contains("targets"))
      for (const auto& tj : j.at("targets")) {
        FileTargetSource t;
        t.character = tj.at("character").get<std::int32_t>();
        std::vector<std::string> files;
        std::stringstream ss(tj.at("file").get<std::string>());
        for (std::string f; std::getline(ss, f, ',');)
          if (!f.empty()) files.push_back(f);
        GATCORE_CHECK(!files.empty(), path, ": a target has no file");
        for (const std::string& f : resolve(files, path)) t.file += (t.file.empty() ? "" : ",") + f;
        const std::string m = tj.at("motion").get<std::string>();
        t.motion = m == "clip" || m.rfind("clip:", 0) == 0 ? m : resolve({m}, path)[0];
        t.animation = tj.value("animation", "");
        if (tj.contains("first_frame")) t.first_frame = tj.at("first_frame").get<double>();
        d.targets.push_back(std::move(t));
      }
    d.subsample = j.at("subsample").get<std::int64_t>();
    // Absent in datasets written before the field: the paper's features only.
    if (j.contains("distortion_scales")) {
      d.distortion_scales = j.at("distortion_scales").get<std::vector<int>>();
      check_distortion_scales(d.distortion_scales, path + ": field \"distortion_scales\"");
    }
    d.validation = j.at("validation").get<float>();
    d.test = j.at("test").get<float>();
    d.split.train = j.at("split").at("train").get<std::vector<std::int32_t>>();
    d.split.validation = j.at("split").at("validation").get<std::vector<std::int32_t>>();
    d.split.test = j.at("split").at("test").get<std::vector<std::int32_t>>();
    const auto n = static_cast<std::int32_t>(d.characters.size());
    for (const auto* v : {&d.split.train, &d.split.validation, &d.split.test})
      for (std::int32_t c : *v) GATCORE_CHECK(c >= 0 && c < n, path, ": split names character ", c, " of ", n);
    std::vector<char> has_target(std::size_t(n), 0);
    for (const FileTargetSource& t : d.targets) {
      GATCORE_CHECK(t.character >= 0 && t.character < n, path, ": a target names character ", t.character, " of ", n);
      GATCORE_CHECK(!has_target[std::size_t(t.character)], path, ": character ", t.character, " has two targets");
      has_target[std::size_t(t.character)] = 1;
    }
    return d;
  } catch (const nlohmann::json::exception& e) {
    throw InvalidArgument(detail::cat(path, ": bad dataset description: ", e.what()));
  }
}

Character load_dataset_character(const std::string& entry) {
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
      const Clip clip = retarget(m, pc.character.skeleton, mat4_identity());
      for (std::size_t f = 0; f < clip.frames.size(); f += static_cast<std::size_t>(d.motion_stride))
        add(clip.frames[f], index++);
    }
  }
  return tasks;
}

}  // namespace gatcore::character
