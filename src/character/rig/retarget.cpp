#include <algorithm>
#include <cmath>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

RetargetMap RetargetMap::cmu_to_humanoid() {
  RetargetMap m;
  m.pairs = {{"Hips", "Hips"},           {"LowerBack", "Abdomen"},     {"Spine", "Torso"},
             {"Spine1", "Chest"},        {"Neck", "Neck"},             {"Head", "Head"},
             {"LeftShoulder", "Shoulder.L"}, {"LeftArm", "UpperArm.L"}, {"LeftForeArm", "LowerArm.L"},
             {"LeftHand", "Hand.L"},     {"RightShoulder", "Shoulder.R"}, {"RightArm", "UpperArm.R"},
             {"RightForeArm", "LowerArm.R"}, {"RightHand", "Hand.R"},  {"LeftUpLeg", "UpperLeg.L"},
             {"LeftLeg", "LowerLeg.L"},  {"LeftFoot", "Foot.L"},       {"RightUpLeg", "UpperLeg.R"},
             {"RightLeg", "LowerLeg.R"}, {"RightFoot", "Foot.R"}};
  return m;
}

Pose world_bind_pose(const Skeleton& s, const Mat4& bind_to_world) {
  Pose p = bind_pose(s);
  for (std::int32_t j = 0; j < s.num_joints(); ++j)
    if (s.parents[j] < 0)
      p.local[j] = to_transform(mul(inverse(s.root_parent[j]), mul(bind_to_world, inverse(s.inverse_bind[j]))));
  return p;
}

namespace {

Quat conj(const Quat& q) { return {-q[0], -q[1], -q[2], q[3]}; }

// The smallest rotation taking direction a to direction b.
Quat rotation_between(Vec3 a, Vec3 b) {
  auto norm = [](Vec3& v) {
    const float l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0.0f)
      for (float& x : v) x /= l;
    return l > 0.0f;
  };
  if (!norm(a) || !norm(b)) return {0.0f, 0.0f, 0.0f, 1.0f};
  const float d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  Vec3 c = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  if (d < -0.999999f) {  // opposite: any perpendicular axis
    c = std::abs(a[0]) < 0.9f ? Vec3{0.0f, -a[2], a[1]} : Vec3{-a[2], 0.0f, a[0]};
    return quat_from_axis_angle(c, 3.14159265358979f);
  }
  return quat_normalize({c[0], c[1], c[2], 1.0f + d});
}

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }

}  // namespace

Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world, const RetargetMap& map) {
  const Skeleton& src = motion.skeleton;
  const std::int32_t J = target.num_joints();
  std::vector<std::int32_t> source_of(static_cast<std::size_t>(J), -1);
  std::int32_t hips_t = -1, hips_s = -1;
  for (const auto& [sn, tn] : map.pairs) {
    const std::int32_t s = src.find(sn), t = target.find(tn);
    if (s < 0 || t < 0) continue;
    source_of[t] = s;
    if (hips_t < 0) {
      hips_t = t;
      hips_s = s;
    }
  }
  GATCORE_CHECK(hips_t >= 0, motion.name, ": no joint of the motion maps onto the target skeleton");
  const Pose t_rest = world_bind_pose(target, bind_to_world);
  const std::vector<Mat4> tg0 = global_transforms(target, t_rest);
  const std::vector<Mat4> sg0 = global_transforms(src, rest_pose(src));
  // Rest-pose alignment per mapped joint: rotate the target bone (towards its
  // first mapped child) onto the source bone; joints without a mapped child
  // take their parent's alignment.
  const auto tchildren = target.children();
  std::vector<Quat> align(static_cast<std::size_t>(J), Quat{0.0f, 0.0f, 0.0f, 1.0f});
  for (std::int32_t t = 0; t < J; ++t) {
    if (source_of[t] < 0) continue;
    std::int32_t tc = -1;
    for (std::int32_t c : tchildren[t])
      if (source_of[c] >= 0 && tc < 0) tc = c;
    if (tc < 0) {
      for (std::int32_t p = target.parents[t]; p >= 0; p = target.parents[p])
        if (source_of[p] >= 0) {
          align[t] = align[p];
          break;
        }
      continue;
    }
    // Target bone direction; the source direction to the source counterpart of tc.
    const Vec3 dt = sub(mat4_translation(tg0[tc]), mat4_translation(tg0[t]));
    const Vec3 ds = sub(mat4_translation(sg0[source_of[tc]]), mat4_translation(sg0[source_of[t]]));
    align[t] = rotation_between(dt, ds);
  }
  // Root translation scale: hip heights above the lowest joint.
  auto height = [](const std::vector<Mat4>& g, std::int32_t hips) {
    float lo = g[hips][13];
    for (const Mat4& m : g) lo = std::min(lo, m[13]);
    return g[hips][13] - lo;
  };
  const float hs = height(sg0, hips_s), ht = height(tg0, hips_t);
  const float scale = hs > 0.0f ? ht / hs : 1.0f;
  // Ground: the lowest any source joint goes over the clip; the target's is
  // its lowest joint in the bind pose. Horizontal motion starts at the
  // target's rest place (the source hips' first-frame position).
  std::vector<std::vector<Mat4>> sg_all;
  sg_all.reserve(motion.clip.frames.size());
  bool first = true;
  float s_ground = 0.0f, t_ground = tg0[hips_t][13];
  for (const Mat4& m : tg0) t_ground = std::min(t_ground, m[13]);
  for (const Pose& frame : motion.clip.frames) {
    sg_all.push_back(global_transforms(src, frame));
    for (const Mat4& m : sg_all.back()) {
      s_ground = first ? m[13] : std::min(s_ground, m[13]);
      first = false;
    }
  }
  const Vec3 s_start = sg_all.empty() ? Vec3{0.0f, 0.0f, 0.0f} : mat4_translation(sg_all[0][hips_s]);

  // The root motion moves the whole skeleton: it goes on the topmost
  // ancestor of the hips. Rigs whose legs hang off a root above the hips
  // (Quaternius: Root -> Hips, Root -> UpperLeg.L) would otherwise leave the
  // legs behind while the body walks away.
  std::int32_t mover = hips_t;
  while (target.parents[mover] >= 0) mover = target.parents[mover];

  Clip out;
  out.name = motion.clip.name;
  out.fps = motion.clip.fps;
  out.frames.reserve(motion.clip.frames.size());
  std::vector<Mat4> tg(static_cast<std::size_t>(J));
  for (const std::vector<Mat4>& sg : sg_all) {
    Pose p = t_rest;
    // Where the hips go this frame, and how far that is from their rest place.
    const Vec3 h = mat4_translation(sg[hips_s]);
    const Vec3 hips_rest = mat4_translation(tg0[hips_t]);
    const Vec3 hips_at = {hips_rest[0] + scale * (h[0] - s_start[0]), t_ground + scale * (h[1] - s_ground),
                          hips_rest[2] + scale * (h[2] - s_start[2])};
    const Vec3 shift = sub(hips_at, hips_rest);
    for (std::int32_t t = 0; t < J; ++t) {
      const Mat4 parent = target.parents[t] >= 0 ? tg[target.parents[t]] : target.root_parent[t];
      const std::int32_t s = source_of[t];
      if (s < 0) {
        tg[t] = mul(parent, to_matrix(t_rest.local[t]));
        if (t == mover) {
          for (int c = 0; c < 3; ++c) tg[t][12 + c] += shift[c];
          p.local[t] = to_transform(mul(inverse(parent), tg[t]));
        }
        continue;
      }
      const Transform rest_world = to_transform(tg0[t]);
      const Quat d = quat_mul(to_transform(sg[s]).rotation, conj(to_transform(sg0[s]).rotation));
      Transform w;
      w.rotation = quat_normalize(quat_mul(d, quat_mul(align[t], rest_world.rotation)));
      w.scale = rest_world.scale;
      w.translation = transform_point(parent, t_rest.local[t].translation);
      if (t == mover) w.translation = add(w.translation, shift);
      tg[t] = to_matrix(w);
      p.local[t] = to_transform(mul(inverse(parent), tg[t]));
    }
    out.frames.push_back(std::move(p));
  }
  return out;
}

std::vector<JointLimit> uniform_limits(const Skeleton& s, float max_angle) {
  std::vector<JointLimit> l(static_cast<std::size_t>(s.num_joints()));
  for (std::int32_t j = 0; j < s.num_joints(); ++j)
    if (s.parents[j] >= 0) {
      l[j].lo = {-max_angle, -max_angle, -max_angle};
      l[j].hi = {max_angle, max_angle, max_angle};
    }
  return l;
}

Pose random_pose(const Skeleton& s, const Pose& rest, const std::vector<JointLimit>& limits, std::mt19937& rng) {
  GATCORE_CHECK(static_cast<std::int32_t>(limits.size()) == s.num_joints() &&
                    static_cast<std::int32_t>(rest.local.size()) == s.num_joints(),
                "random_pose: ", limits.size(), " limits and ", rest.local.size(), " rest transforms for ",
                s.num_joints(), " joints");
  Pose p = rest;
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    Quat q = {0.0f, 0.0f, 0.0f, 1.0f};
    for (int a = 0; a < 3; ++a) {
      GATCORE_CHECK(limits[j].lo[a] <= limits[j].hi[a], "random_pose: joint '", s.names[j], "' axis ", a,
                    " has lower limit ", limits[j].lo[a], " above upper limit ", limits[j].hi[a]);
      // Sample with integer draws mapped to [0, 1] so the sequence is the
      // same across standard libraries.
      const float u = static_cast<float>(rng() >> 8) / static_cast<float>(1u << 24);
      const float angle = limits[j].lo[a] + u * (limits[j].hi[a] - limits[j].lo[a]);
      Vec3 axis{0.0f, 0.0f, 0.0f};
      axis[a] = 1.0f;
      q = quat_mul(q, quat_from_axis_angle(axis, angle));
    }
    p.local[j].rotation = quat_normalize(quat_mul(rest.local[j].rotation, q));
  }
  return p;
}

}  // namespace gatcore::character
