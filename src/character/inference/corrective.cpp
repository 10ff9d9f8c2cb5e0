#include "gatcore/character/inference/corrective.hpp"

#include <chrono>
#include <cmath>

#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/character/features/nearest_joints.hpp"
#include "gatcore/error.hpp"
#include "gatcore/models/predict.hpp"

namespace gatcore::character {

CorrectiveBinding make_corrective_binding(const Character& ch, const std::vector<std::string>& bones,
                                            const BoneAliases& aliases, std::span<const int> distortion_scales,
                                            int nearest_joints) {
  CorrectiveBinding d;
  // No Delta Mush smoothing (iterations 0): only its one-ring adjacency is
  // used (distortion columns), with the mesh graph and the normalisation.
  d.prepared = prepare_character(ch, DeltaMushParams{0, 0.5f}, distortion_scales);
  d.nearest_joints = nearest_joints;
  if (nearest_joints > 0) {
    GATCORE_CHECK(ch.skeleton.num_joints() > 0, ch.name, ": no joints");
    return d;  // no names to match
  }
  d.mapping = map_bones(ch.skeleton, bones, aliases, ch.name);
  d.num_bones = static_cast<std::int64_t>(bones.size());
  return d;
}

CorrectedFrame deform_frame(const CorrectiveBinding& d, models::Model& model, const models::Normaliser& norm,
                            const Pose& pose) {
  GATCORE_CHECK(model.config().task == models::Task::displacement, d.prepared.character.name, ": ",
                model.config().name, " predicts skin weights, not displacements");
  const PreparedCharacter& pc = d.prepared;
  const auto t0 = std::chrono::steady_clock::now();
  // The whole mesh's features, as a training sample computes them (without
  // the Delta Mush target).
  const PosedFrame frame = pose_frame(pc, pose);
  const std::vector<std::int32_t> vertices = all_vertices(pc.character.mesh.num_vertices());
  models::Sample s;
  s.name = pc.character.name;
  const Tensor joint_features = densegats_frame_features(frame, vertices);
  s.features = densegats_model_features(d.nearest_joints > 0 ? nearest_joint_columns(joint_features, d.nearest_joints)
                                                             : features_in_bone_order(joint_features, d.mapping),
                                        distortion_frame_features(pc, frame, vertices));
  GATCORE_CHECK(s.features.cols() == model.config().in_dim, s.name, ": ", s.features.cols(),
                " features (bones and distortion scales) for a model that takes ", model.config().in_dim);
  s.graph = share(induced_subgraph(pc.mesh_graph, vertices));
  const auto t1 = std::chrono::steady_clock::now();
  const Tensor y = models::predict(model, s, norm);
  const auto t2 = std::chrono::steady_clock::now();
  CorrectedFrame f;
  const std::int64_t n = static_cast<std::int64_t>(vertices.size());
  f.lbs.resize(static_cast<std::size_t>(3 * n));
  f.corrected.resize(f.lbs.size());
  // Normalised p' = (p - origin) * scale: back to world units.
  const float inv = 1.0f / pc.normalisation.scale;
  for (std::int64_t v = 0; v < n; ++v) {
    // The model predicts in the root frame (frame_features.hpp).
    const Vec3 o = root_offset_to_world(frame.root_motion, {y.at(v, 0), y.at(v, 1), y.at(v, 2)});
    for (int c = 0; c < 3; ++c) {
      const float l = frame.lbs[3 * v + c] * inv + pc.normalisation.origin[c];
      const float off = o[std::size_t(c)] * inv;
      GATCORE_CHECK(std::isfinite(off), s.name, ": the model predicted a non-finite offset at vertex ", v);
      f.lbs[3 * v + c] = l;
      f.corrected[3 * v + c] = l + off;
    }
  }
  f.ms_features = std::chrono::duration<double, std::milli>(t1 - t0).count();
  f.ms_inference = std::chrono::duration<double, std::milli>(t2 - t1).count();
  return f;
}

}  // namespace gatcore::character
