// The rig's bone-axis convention by vote (see the header).
#include "gatcore/character/rig/bone_axis.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gatcore/character/rig/vec3.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

using V3 = Vec3d;

// d / |d| by division per component (not normalise's reciprocal: the vote's
// directions stay as they were measured); the zero vector stays zero.
V3 unit(V3 d) {
  const double l = length(d);
  for (double& x : d) x = l > 0 ? x / l : 0.0;
  return d;
}

// Signed local axis a of a bind frame (a / 2: X, Y, Z; odd: negative).
V3 frame_axis(const Mat4& bind, int a) {
  V3 d = unit({bind[std::size_t(4 * (a / 2))], bind[std::size_t(4 * (a / 2) + 1)], bind[std::size_t(4 * (a / 2) + 2)]});
  if (a % 2)
    for (double& x : d) x = -x;
  return d;
}

// Unit direction between two bind frames' origins.
V3 dir(const Mat4& from, const Mat4& to) {
  const Vec3 a = mat4_translation(from), b = mat4_translation(to);
  return unit({double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]});
}

Mat4 bind_of(const Skeleton& s, std::int32_t j) { return inverse(s.inverse_bind[std::size_t(j)]); }

}  // namespace

BoneAxis bone_axis_convention(const Skeleton& s) {
  const std::int32_t nj = s.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(s.inverse_bind.size()) == nj, "bone_axis_convention: ",
                s.inverse_bind.size(), " inverse bind matrices for ", nj, " joints");
  std::vector<Mat4> bind(static_cast<std::size_t>(nj));
  for (std::int32_t j = 0; j < nj; ++j) bind[std::size_t(j)] = bind_of(s, j);
  const auto children = s.children();
  int votes[6] = {0, 0, 0, 0, 0, 0};
  for (std::int32_t j = 0; j < nj; ++j) {
    if (children[std::size_t(j)].size() != 1) continue;
    const V3 d = dir(bind[std::size_t(j)], bind[std::size_t(children[std::size_t(j)][0])]);
    if (dot(d, d) == 0) continue;
    int best = 0;
    for (int a = 1; a < 6; ++a)
      if (dot(frame_axis(bind[std::size_t(j)], a), d) > dot(frame_axis(bind[std::size_t(j)], best), d)) best = a;
    ++votes[best];
  }
  const int conv = static_cast<int>(std::max_element(votes, votes + 6) - votes);
  if (votes[conv] == 0) return {};
  return {conv / 2, conv % 2 ? -1 : 1};
}

Vec3 bone_direction(const Skeleton& s, std::int32_t j, const BoneAxis& convention) {
  GATCORE_CHECK(j >= 0 && j < s.num_joints(), "bone_direction: joint ", j, " of ", s.num_joints());
  const Mat4 b = bind_of(s, j);
  V3 d{0, 0, 0};
  for (std::int32_t c = 0; c < s.num_joints(); ++c)
    if (s.parents[std::size_t(c)] == j) {
      d = dir(b, bind_of(s, c));
      break;
    }
  if (dot(d, d) == 0 && convention.axis >= 0)
    d = frame_axis(b, 2 * convention.axis + (convention.sign < 0 ? 1 : 0));
  else if (dot(d, d) == 0 && s.parents[std::size_t(j)] >= 0)
    d = dir(bind_of(s, s.parents[std::size_t(j)]), b);
  return {float(d[0]), float(d[1]), float(d[2])};
}

}  // namespace gatcore::character
