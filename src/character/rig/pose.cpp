#include "gatcore/character/rig/pose.hpp"

#include <algorithm>
#include <cmath>

#include "gatcore/error.hpp"

namespace gatcore::character {

Pose rest_pose(const Skeleton& s) { return Pose{s.rest_local}; }

int clip_frame_count(double duration_s, double fps, std::int32_t joints, const std::string& what) {
  GATCORE_CHECK(std::isfinite(fps) && fps > 0, what, ": sampling rate ", fps, " fps");
  GATCORE_CHECK(std::isfinite(duration_s) && duration_s >= 0, what, ": duration ", duration_s, " s");
  const double frames = std::floor(duration_s * fps + 1e-3) + 1;
  const double limit = double(kMaxClipJointSamples) / double(std::max(1, joints));
  GATCORE_CHECK(frames <= limit, what, " lasts ", duration_s, " s: ", frames, " frames at ", fps, " fps of ", joints,
                " joints, more than the ", kMaxClipJointSamples, " joint samples a clip may hold");
  return static_cast<int>(frames);
}

Pose bind_pose(const Skeleton& s) {
  const std::int32_t n = s.num_joints();
  std::vector<Mat4> bind_global(static_cast<std::size_t>(n));
  Pose p;
  p.local.resize(static_cast<std::size_t>(n));
  for (std::int32_t j = 0; j < n; ++j) {
    bind_global[j] = inverse(s.inverse_bind[j]);
    const Mat4 parent = s.parents[j] >= 0 ? bind_global[s.parents[j]] : s.root_parent[j];
    p.local[j] = to_transform(mul(inverse(parent), bind_global[j]));
  }
  return p;
}

std::vector<Mat4> global_transforms(const Skeleton& s, const Pose& p) {
  const std::int32_t n = s.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(p.local.size()) == n, "pose has ", p.local.size(),
                " joint transforms, skeleton has ", n, " joints");
  std::vector<Mat4> g(static_cast<std::size_t>(n));
  for (std::int32_t j = 0; j < n; ++j) {
    const Mat4 parent = s.parents[j] >= 0 ? g[s.parents[j]] : s.root_parent[j];
    g[j] = mul(parent, to_matrix(p.local[j]));
  }
  return g;
}

std::vector<Mat4> skinning_matrices(const Skeleton& s, const Pose& p) {
  std::vector<Mat4> g = global_transforms(s, p);
  for (std::size_t j = 0; j < g.size(); ++j) g[j] = mul(g[j], s.inverse_bind[j]);
  return g;
}

}  // namespace gatcore::character
