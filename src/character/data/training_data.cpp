#include "gatcore/character/data/training_data.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "gatcore/character/data/file_targets.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/character/inference/model_description.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

const char* dataset_part_name(DatasetPart p) {
  switch (p) {
    case DatasetPart::train: return "train";
    case DatasetPart::validation: return "validation";
    case DatasetPart::test: return "test";
  }
  return "?";
}

const std::vector<std::int32_t>& TrainingData::part(DatasetPart p) const {
  switch (p) {
    case DatasetPart::validation: return description.split.validation;
    case DatasetPart::test: return description.split.test;
    default: return description.split.train;
  }
}

std::int64_t TrainingData::feature_dim(models::Task task) const {
  return task == models::Task::displacement ? displacement_feature_dim(nearest_joints) : 6 + super.num_bones();
}

std::int64_t TrainingData::displacement_feature_dim(int nearest) const {
  const auto S = static_cast<std::int64_t>(description.distortion_scales.size());
  return 6 + (nearest > 0 ? nearest : super.num_bones()) + 3 * S;
}

std::string file_hash(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  GATCORE_CHECK(f.good(), path, ": cannot open file");
  std::uint64_t h = 1469598103934665603ull;
  for (std::istreambuf_iterator<char> it(f), end; it != end; ++it) {
    h ^= static_cast<unsigned char>(*it);
    h *= 1099511628211ull;
  }
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(h));
  return b;
}

TrainingData load_training_data(const std::string& path, const ProgressFn& progress) {
  TrainingData t;
  t.path = path;
  t.description = load_dataset(path);
  t.hash = file_hash(path);
  const DatasetDescription& d = t.description;
  GATCORE_CHECK(!d.characters.empty(), path, ": the dataset has no characters");
  for (std::size_t c = 0; c < d.characters.size(); ++c) {
    const std::string& e = d.characters[c];
    report_progress(progress, std::int64_t(c), std::int64_t(d.characters.size()));
    try {
      const Character file_character = load_dataset_character(e);
      t.characters.push_back(prepare_character(file_character, d.delta_mush, d.distortion_scales));
      PreparedCharacter& pc = t.characters.back();
      if (d.reference == ReferenceKind::arap) pc.reference = arap_reference(pc.character.mesh, d.arap);
      for (const FileTargetSource& src : d.targets)
        if (src.character == static_cast<std::int32_t>(c)) attach_file_targets(pc, file_character, src, path);
    } catch (const std::exception& ex) {
      throw InvalidArgument(detail::cat(path, ": character '", e, "': ", ex.what()));
    }
  }
  report_progress(progress, std::int64_t(d.characters.size()), std::int64_t(d.characters.size()));
  for (const std::string& m : d.motions) {
    try {
      t.motions.push_back(load_motion(m));
    } catch (const std::exception& ex) {
      throw InvalidArgument(detail::cat(path, ": motion '", m, "': ", ex.what()));
    }
  }
  std::vector<const Skeleton*> sk;
  for (const auto& pc : t.characters) sk.push_back(&pc.character.skeleton);
  t.super = build_super_skeleton(sk);
  return t;
}

std::string joined_bone_names(const SuperSkeleton& s) { return joined_bone_names(s.names); }

namespace {

// [m, 6 + J] in the character's joint order -> [m, 6 + B] in the super skeleton's.
Tensor to_super_columns(const Tensor& f, const std::vector<std::int32_t>& joint_to_bone, std::int32_t B) {
  Tensor out = Tensor::zeros(f.rows(), 6 + B);
  for (std::int64_t i = 0; i < f.rows(); ++i) {
    for (int c = 0; c < 6; ++c) out.at(i, c) = f.at(i, c);
    for (std::size_t j = 0; j < joint_to_bone.size(); ++j) out.at(i, 6 + joint_to_bone[j]) = f.at(i, 6 + std::int64_t(j));
  }
  return out;
}

}  // namespace

Tensor displacement_model_features(const TrainingData& data, const DenseGatsSample& s, int nearest) {
  const Tensor joints = nearest > 0 ? nearest_joint_columns(s.features, nearest)
                                    : to_super_columns(s.features, data.super.joint_to_bone[std::size_t(s.character)],
                                                       data.super.num_bones());
  return densegats_model_features(joints, s);
}

std::vector<models::Sample> training_samples(const TrainingData& data, models::Task task, DatasetPart part,
                                             int epoch, int geodesic_k, int max_poses_per_character,
                                             const SampleFilter& build, const ProgressFn& progress) {
  const auto& chars = data.part(part);
  const std::int32_t B = data.super.num_bones();
  std::vector<models::Sample> out;
  if (task == models::Task::displacement) {
    std::vector<SampleTask> tasks = dataset_tasks(data.description, data.characters, data.motions, chars, epoch);
    if (max_poses_per_character > 0)
      std::erase_if(tasks, [&](const SampleTask& t) { return t.pose_index >= max_poses_per_character; });
    const auto name = [&](std::int32_t character, std::int32_t pose) {
      return data.description.characters[std::size_t(character)] + " pose " + std::to_string(pose);
    };
    // The samples not to build: stubs that know their vertex count (make_densegats_sample's window).
    std::vector<std::size_t> where;  // out index of each task built
    std::vector<SampleTask> todo;
    out.resize(tasks.size());
    for (std::size_t i = 0; i < tasks.size(); ++i) {
      const SampleTask& t = tasks[i];
      if (!build || build(i, tasks.size())) {
        where.push_back(i);
        todo.push_back(t);
        continue;
      }
      const std::int64_t n = data.characters[std::size_t(t.character)].character.mesh.num_vertices();
      CsrGraph g;
      g.num_nodes = t.count <= 0 || t.count >= n ? n : t.count;
      out[i].name = name(t.character, t.pose_index);
      out[i].graph = share(std::move(g));
    }
    std::size_t k = 0;
    stream_densegats_samples(data.characters, todo, [&](DenseGatsSample&& s) {
      models::Sample& m = out[where[k++]];
      m.name = name(s.character, s.pose);
      m.features = displacement_model_features(data, s, data.nearest_joints);
      m.target = std::move(s.target);
      m.graph = share(std::move(s.graph));
      report_progress(progress, std::int64_t(k), std::int64_t(todo.size()));
    });
    return out;
  }
  GATCORE_CHECK(geodesic_k >= 1, "training_samples: geodesic_k must be >= 1, got ", geodesic_k);
  for (std::int32_t c : chars) {
    report_progress(progress, std::int64_t(out.size()), std::int64_t(chars.size()));
    const PreparedCharacter& pc = data.characters[std::size_t(c)];
    NeuroSkinningSample s = make_neuroskinning_sample(pc);
    const auto& j2b = data.super.joint_to_bone[std::size_t(c)];
    models::Sample m;
    m.name = data.description.characters[std::size_t(c)];
    m.features = to_super_columns(s.features, j2b, B);
    const std::vector<float> w = super_weights(pc.character.mesh.weights, j2b, B);
    m.target = Tensor::empty(s.weights.rows(), B);
    for (std::int64_t i = 0; i < m.target.rows(); ++i)
      for (std::int32_t b = 0; b < B; ++b) m.target.at(i, b) = w[std::size_t(i * B + b)];
    m.bone_mask = Tensor::empty(1, B);
    for (std::int32_t b = 0; b < B; ++b) m.bone_mask.at(0, b) = data.super.mask[std::size_t(c)][std::size_t(b)] ? 1.f : 0.f;
    m.graph = share(std::move(s.graph));
    m.geodesic_neighbours = geodesic_knn_lists(pc.character.mesh.positions, pc.character.mesh.triangles, geodesic_k);
    out.push_back(std::move(m));
  }
  return out;
}

models::Sample densegats_full_sample(const TrainingData& data, std::int32_t character, const Pose& pose,
                                     DenseGatsSample* raw, std::int32_t target_frame) {
  GATCORE_CHECK(character >= 0 && character < static_cast<std::int32_t>(data.characters.size()),
                "densegats_full_sample: character ", character, " of ", data.characters.size());
  DenseGatsSample s = make_densegats_sample(data.characters[std::size_t(character)], pose, 0, 0, true, target_frame);
  s.character = character;
  models::Sample m;
  m.name = data.description.characters[std::size_t(character)];
  m.features = displacement_model_features(data, s, data.nearest_joints);
  m.target = s.target;
  m.graph = share(std::move(s.graph));
  if (raw) *raw = std::move(s);
  return m;
}

}  // namespace gatcore::character
