#include "gatcore/character/inference/character_model.hpp"

#include <cmath>
#include <map>
#include <sstream>

#include "gatcore/character/deform/detail_distortion.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::vector<std::string> character_model_bones(const models::LoadedModel& m, const std::string& path,
                                               models::Task task) {
  const models::ModelConfig& cfg = m.model->config();
  const bool weights = task == models::Task::weights;
  GATCORE_CHECK(cfg.task == task, path, ": holds a ", cfg.name, " model for ", models::task_name(cfg.task),
                ", not one for ", models::task_name(task), " (use ",
                weights ? "neuroskinning, neuroskinning-nopool, pointnet or fc" : "densegats, its ablations or origat",
                ")");
  const ModelDescription d = read_model_description(m.file, path);
  const FeatureKind fk = d.features;
  GATCORE_CHECK(fk != FeatureKind::tube, path,
                ": was trained on the embedded tube data, whose features are not character features; train it on "
                "a dataset (gat dataset build, gat train --data)");
  GATCORE_CHECK((fk == FeatureKind::neuroskinning) == weights, path, ": was trained on ", feature_kind_name(fk),
                " features, not ", weights ? "neuroskinning" : "densegats", " features");
  GATCORE_CHECK(!d.skeleton.empty(), path,
                ": the metadata has no 'skeleton' (the bone names the model was trained on)");
  const std::vector<std::string>& bones = d.skeleton;
  const auto B = static_cast<std::int64_t>(bones.size());
  const auto S = weights ? 0 : static_cast<std::int64_t>(d.distortion_scales.size());
  const int K = weights ? 0 : d.nearest_joints;
  if (K > 0)
    GATCORE_CHECK(cfg.in_dim == 6 + K + 3 * S, path, ": the model takes ", cfg.in_dim, " features but its metadata "
                  "says ", K, " nearest joints and ", S, " distortion scales (expected 6 + ", K, " + 3 * ", S, ")");
  else
    GATCORE_CHECK(cfg.in_dim == 6 + B + 3 * S, path, ": the model takes ", cfg.in_dim, " features but its skeleton has ",
                  B, " bones and ", S, " distortion scales (expected 6 + ", B, " + 3 * ", S, ")");
  GATCORE_CHECK(!weights || cfg.out_dim == B, path, ": the model outputs ", cfg.out_dim, " bones but its skeleton has ",
                B);
  return bones;
}

std::int32_t BoneMapping::num_mapped() const {
  std::int32_t n = 0;
  for (std::int32_t j : bone_to_joint) n += j >= 0;
  return n;
}

BoneMapping map_bones(const Skeleton& s, const std::vector<std::string>& bones, const BoneAliases& aliases,
                      const std::string& what) {
  std::map<std::string, std::int32_t> index;
  for (std::size_t b = 0; b < bones.size(); ++b) index.emplace(bones[b], static_cast<std::int32_t>(b));
  BoneMapping m;
  m.joint_to_bone.assign(static_cast<std::size_t>(s.num_joints()), -1);
  m.bone_to_joint.assign(bones.size(), -1);
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    const auto it = index.find(aliases.apply(normalise_bone_name(s.names[j])));
    if (it == index.end()) {
      m.unmapped.push_back(s.names[j]);
      continue;
    }
    const std::int32_t other = m.bone_to_joint[it->second];
    GATCORE_CHECK(other < 0, what, ": joints '", s.names[other], "' and '", s.names[j], "' both map to bone '",
                  it->first, "'");
    m.bone_to_joint[it->second] = j;
    m.joint_to_bone[j] = it->second;
  }
  if (m.num_mapped() == 0) {
    std::string js, bs;
    for (std::int32_t j = 0; j < std::min<std::int32_t>(s.num_joints(), 6); ++j) js += (j ? ", " : "") + s.names[j];
    for (std::size_t b = 0; b < std::min<std::size_t>(bones.size(), 6); ++b) bs += (b ? ", " : "") + bones[b];
    throw InvalidArgument(detail::cat(what, ": none of its ", s.num_joints(), " joints (", js,
                                      s.num_joints() > 6 ? ", ..." : "", ") matches a bone of the model (", bs,
                                      bones.size() > 6 ? ", ..." : "", "); add name aliases (--alias JOINT=BONE)"));
  }
  return m;
}

Tensor features_in_bone_order(const Tensor& f, const BoneMapping& m) {
  const auto J = static_cast<std::int64_t>(m.joint_to_bone.size()), B = static_cast<std::int64_t>(m.bone_to_joint.size());
  GATCORE_CHECK(f.cols() == 6 + J, "features_in_bone_order: ", f.cols(), " columns for ", J, " joints");
  Tensor out = Tensor::zeros(f.rows(), 6 + B);
  for (std::int64_t i = 0; i < f.rows(); ++i) {
    for (int c = 0; c < 6; ++c) out.at(i, c) = f.at(i, c);
    for (std::int64_t j = 0; j < J; ++j)
      if (m.joint_to_bone[j] >= 0) out.at(i, 6 + m.joint_to_bone[j]) = f.at(i, 6 + j);
  }
  return out;
}

std::vector<std::string> unseen_absent_bones(const BoneMapping& m, const std::vector<std::string>& bones,
                                             const BonePresence& presence) {
  std::vector<std::string> out;
  if (presence.count.empty() || presence.characters == 0) return out;
  GATCORE_CHECK(bones.size() == m.bone_to_joint.size() && presence.count.size() == bones.size(),
                "unseen_absent_bones: ", bones.size(), " bone names, a mapping of ", m.bone_to_joint.size(),
                " bones, ", presence.count.size(), " presence counts");
  for (std::size_t b = 0; b < bones.size(); ++b)
    if (m.bone_to_joint[b] < 0 && presence.count[b] == presence.characters) out.push_back(bones[b]);
  return out;
}

std::string unseen_absent_bones_warning(const std::string& what, const std::vector<std::string>& absent,
                                        const BonePresence& presence) {
  if (absent.empty()) return "";
  std::string names;
  for (std::size_t i = 0; i < absent.size() && i < 8; ++i) {
    if (i) names += ", ";
    names += absent[i];
  }
  if (absent.size() > 8) names += ", ...";
  return "warning: " + what + " lacks " + std::to_string(absent.size()) + " of the model's " +
         std::to_string(presence.count.size()) + " bones that all " + std::to_string(presence.characters) +
         " training characters had (" + names +
         "): their columns read 'absent', an input this model never saw, which can spoil its output on the whole "
         "mesh";
}

}  // namespace gatcore::character
