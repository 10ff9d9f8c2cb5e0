#include "gatcore/character/inference/model_description.hpp"

#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

FeatureKind checkpoint_features(const models::CheckpointFile& f) {
  const auto& md = f.metadata;
  const auto task = [&] {
    const auto it = md.find("config");
    return it != md.end() ? models::ModelConfig::from_text(it->second).task : models::Task::displacement;
  };
  if (const auto it = md.find("features"); it != md.end()) {
    // Exact names; a longer description starting with one (checkpoints of an
    // interim version wrote the layout here) means the same.
    if (it->second.rfind("neuroskinning", 0) == 0) return FeatureKind::neuroskinning;
    if (it->second.rfind("densegats", 0) == 0) return FeatureKind::densegats;
    if (it->second == "bone-candidates") return FeatureKind::bone_candidates;
    return FeatureKind::tube;
  }
  if (!md.count("data_path")) return FeatureKind::tube;
  return task() == models::Task::weights ? FeatureKind::neuroskinning : FeatureKind::densegats;
}

const char* feature_kind_name(FeatureKind k) {
  switch (k) {
    case FeatureKind::neuroskinning: return "neuroskinning";
    case FeatureKind::densegats: return "densegats";
    case FeatureKind::bone_candidates: return "bone-candidates";
    default: return "tube";
  }
}

std::vector<int> checkpoint_distortion_scales(const models::CheckpointFile& f, const std::string& path) {
  const auto it = f.metadata.find("distortion_scales");
  if (it == f.metadata.end()) return {};
  return parse_distortion_scales(it->second, path + ": metadata 'distortion_scales'");
}

int checkpoint_nearest_joints(const models::CheckpointFile& f, const std::string& path) {
  const auto it = f.metadata.find("joint_columns");
  return it == f.metadata.end() ? 0 : parse_joint_columns(it->second, path + ": metadata 'joint_columns'");
}

BonePresence checkpoint_bone_presence(const models::CheckpointFile& f, const std::string& path,
                                      std::size_t num_bones) {
  BonePresence p;
  const auto& md = f.metadata;
  const auto c = md.find("bone_presence"), n = md.find("training_characters");
  if (c == md.end() && n == md.end()) return p;
  GATCORE_CHECK(c != md.end() && n != md.end(), path, ": metadata 'bone_presence' and 'training_characters' go together");
  const auto num = [&](const std::string& field, const std::string& v) {
    std::size_t end = 0;
    long x = -1;
    try {
      x = std::stol(v, &end);
    } catch (const std::exception&) {
      end = 0;
    }
    GATCORE_CHECK(end == v.size() && !v.empty() && x >= 0 && x <= 100000000, path, ": metadata '", field,
                  "': bad count '", v, "'");
    return int(x);
  };
  p.characters = num("training_characters", n->second);
  std::stringstream ss(c->second);
  for (std::string item; std::getline(ss, item, ',');) {
    p.count.push_back(num("bone_presence", item));
    GATCORE_CHECK(p.count.back() <= p.characters, path, ": metadata 'bone_presence': ", p.count.back(),
                  " characters of ", p.characters);
  }
  GATCORE_CHECK(p.count.size() == num_bones, path, ": metadata 'bone_presence' has ", p.count.size(), " counts for ",
                num_bones, " bones");
  return p;
}

std::string format_bone_presence(const std::vector<int>& count) {
  std::string s;
  for (std::size_t i = 0; i < count.size(); ++i) {
    if (i) s += ',';
    s += std::to_string(count[i]);
  }
  return s;
}

std::string joined_bone_names(const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size(); ++i) s += (i ? "," : "") + names[i];
  return s;
}

namespace {

// The shortest text that reads back as the same float ("0.05", not
// "0.05000000074505806").
std::string float_text(float v) {
  char buf[32];
  for (int digits = 6; digits < 9; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, double(v));
    if (std::strtof(buf, nullptr) == v) return buf;
  }
  std::snprintf(buf, sizeof buf, "%.9g", double(v));
  return buf;
}

}  // namespace

std::map<std::string, std::string> model_description_metadata(const ModelDescription& d) {
  std::map<std::string, std::string> md;
  md["features"] = feature_kind_name(d.features);
  if (!d.data_path.empty()) {
    md["data"] = "dataset";
    md["data_path"] = d.data_path;
    md["data_hash"] = d.data_hash;
  } else {
    md["data"] = "embedded tube character";
  }
  if (!d.skeleton.empty()) md["skeleton"] = joined_bone_names(d.skeleton);
  if (d.world_columns_ignored) md["world_columns"] = *d.world_columns_ignored ? "ignore" : "use";
  if (!d.bone_presence.count.empty()) {
    md["bone_presence"] = format_bone_presence(d.bone_presence.count);
    md["training_characters"] = std::to_string(d.bone_presence.characters);
  }
  if (d.features == FeatureKind::densegats) {
    md["distortion_scales"] = format_distortion_scales(d.distortion_scales);
    md["joint_columns"] = format_joint_columns(d.nearest_joints);
  }
  if (!d.feature_layout.empty()) md["feature_layout"] = d.feature_layout;
  if (d.postprocess) {
    md["min_weight"] = float_text(d.postprocess->min_weight);
    md["heat_blend"] = float_text(d.postprocess->heat_blend);
  }
  return md;
}

ModelDescription read_model_description(const models::CheckpointFile& f, const std::string& path) {
  const auto& md = f.metadata;
  const auto value = [&](const char* key) {
    const auto it = md.find(key);
    return it == md.end() ? std::string() : it->second;
  };
  ModelDescription d;
  d.features = checkpoint_features(f);
  std::stringstream ss(value("skeleton"));
  for (std::string b; std::getline(ss, b, ',');) d.skeleton.push_back(b);
  d.nearest_joints = checkpoint_nearest_joints(f, path);
  d.distortion_scales = checkpoint_distortion_scales(f, path);
  d.bone_presence = checkpoint_bone_presence(f, path, d.skeleton.size());
  if (const std::string w = value("world_columns"); !w.empty()) {
    GATCORE_CHECK(w == "ignore" || w == "use", path, ": metadata 'world_columns': expects ignore or use, got '", w, "'");
    d.world_columns_ignored = w == "ignore";
  }
  d.feature_layout = value("feature_layout");
  d.data_path = value("data_path");
  d.data_hash = value("data_hash");
  d.data = value("data");
  const bool has_min = md.count("min_weight") > 0, has_blend = md.count("heat_blend") > 0;
  GATCORE_CHECK(has_min == has_blend, path, ": metadata has '", has_min ? "min_weight" : "heat_blend",
                "' without '", has_min ? "heat_blend" : "min_weight", "' (a calibrated post-processing records both)");
  if (has_min) {
    WeightPostprocess w;
    w.min_weight = float(models::metadata_number(md, "min_weight", 0.0, 0.999999, path));
    w.heat_blend = float(models::metadata_number(md, "heat_blend", 0.0, 1.0, path));
    d.postprocess = w;
  }
  return d;
}

}  // namespace gatcore::character
