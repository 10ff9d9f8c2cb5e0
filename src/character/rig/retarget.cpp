#include <algorithm>
#include <cctype>
#include <cmath>

#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/character/rig/vec3.hpp"
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
    const float l = length(v);
    if (l > 0.0f)
      for (float& x : v) x /= l;
    return l > 0.0f;
  };
  if (!norm(a) || !norm(b)) return {0.0f, 0.0f, 0.0f, 1.0f};
  const float d = dot(a, b);
  Vec3 c = cross(a, b);
  if (d < -0.999999f) {  // opposite: any perpendicular axis
    c = std::abs(a[0]) < 0.9f ? Vec3{0.0f, -a[2], a[1]} : Vec3{-a[2], 0.0f, a[0]};
    return quat_from_axis_angle(c, 3.14159265358979f);
  }
  return quat_normalize({c[0], c[1], c[2], 1.0f + d});
}

}  // namespace

namespace {

// Which source joint drives each target joint, and along which bone each
// side's rest pose is aligned.
struct Binding {
  std::vector<std::int32_t> source_of;  // per target joint, -1: follows its parent
  std::vector<std::int32_t> aim_t, aim_s;  // per target joint: the joints its bone points to (-1: inherit the parent's alignment)
  std::vector<std::int32_t> anchor;      // per target joint: the mapped body parent it is not under (detached IK feet), or -1
  std::int32_t hips_t = -1, hips_s = -1;  // the pair that carries the root motion
  Mat4 source_to_world = mat4_identity();  // MotionRig::to_world
  bool by_height = false;                  // scale root motion by whole-skeleton heights (no pelvis pair)
};

// A binding of J target joints with nothing mapped yet.
Binding unbound(std::int32_t J) {
  Binding b;
  const auto n = static_cast<std::size_t>(J);
  b.source_of.assign(n, -1);
  b.aim_t.assign(n, -1);
  b.aim_s.assign(n, -1);
  b.anchor.assign(n, -1);
  return b;
}

Clip apply(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world, const Binding& b) {
  const Skeleton& src = motion.skeleton;
  const std::int32_t J = target.num_joints();
  const std::vector<std::int32_t>& source_of = b.source_of;
  const std::int32_t hips_t = b.hips_t, hips_s = b.hips_s;
  const Pose t_rest = world_bind_pose(target, bind_to_world);
  const std::vector<Mat4> tg0 = global_transforms(target, t_rest);
  auto source_globals = [&](const Pose& p) {
    std::vector<Mat4> g = global_transforms(src, p);
    for (Mat4& m : g) m = mul(b.source_to_world, m);
    return g;
  };
  const std::vector<Mat4> sg0 = source_globals(rest_pose(src));
  // Rest-pose alignment per mapped joint: rotate the target bone onto the
  // source bone; joints without an aim take their parent's alignment.
  std::vector<Quat> align(static_cast<std::size_t>(J), Quat{0.0f, 0.0f, 0.0f, 1.0f});
  // Parents first, except detached joints, which wait for their anchor.
  std::vector<std::int32_t> order;
  {
    std::vector<std::uint8_t> state(static_cast<std::size_t>(J), 0);
    std::vector<std::int32_t> stack;
    for (std::int32_t j0 = 0; j0 < J; ++j0) {
      stack.push_back(j0);
      while (!stack.empty()) {
        const std::int32_t j = stack.back();
        if (state[j] == 2) {
          stack.pop_back();
          continue;
        }
        state[j] = 1;
        bool ready = true;
        for (std::int32_t dep : {target.parents[j], b.anchor[j]})
          if (dep >= 0 && state[dep] != 2) {
            GATCORE_CHECK(state[dep] != 1, "retarget: joint '", target.names[j], "' depends on itself");
            stack.push_back(dep);
            ready = false;
          }
        if (!ready) continue;
        stack.pop_back();
        state[j] = 2;
        order.push_back(j);
      }
    }
  }
  for (std::int32_t t : order) {
    if (source_of[t] < 0) continue;
    if (b.aim_t[t] < 0 || b.aim_s[t] < 0) {
      for (std::int32_t p = target.parents[t]; p >= 0; p = target.parents[p])
        if (source_of[p] >= 0) {
          align[t] = align[p];
          break;
        }
      continue;
    }
    const Vec3 dt = sub(mat4_translation(tg0[b.aim_t[t]]), mat4_translation(tg0[t]));
    const Vec3 ds = sub(mat4_translation(sg0[b.aim_s[t]]), mat4_translation(sg0[source_of[t]]));
    align[t] = rotation_between(dt, ds);
  }
  // Root translation scale: hip heights above the lowest joint (or the
  // skeletons' heights when there is no pelvis pair).
  auto height = [](const std::vector<Mat4>& g, std::int32_t hips, bool whole) {
    float lo = g[hips][13], hi = g[hips][13];
    for (const Mat4& m : g) lo = std::min(lo, m[13]), hi = std::max(hi, m[13]);
    return (whole ? hi : g[hips][13]) - lo;
  };
  const float hs = height(sg0, hips_s, b.by_height), ht = height(tg0, hips_t, b.by_height);
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
    sg_all.push_back(source_globals(frame));
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
    // Without a pelvis pair (root motion only) the root moves by the source
    // hips' change from their rest height instead.
    const float y = b.by_height ? hips_rest[1] + scale * (h[1] - mat4_translation(sg0[hips_s])[1])
                                : t_ground + scale * (h[1] - s_ground);
    const Vec3 hips_at = {hips_rest[0] + scale * (h[0] - s_start[0]), y, hips_rest[2] + scale * (h[2] - s_start[2])};
    const Vec3 shift = sub(hips_at, hips_rest);
    for (std::int32_t t : order) {
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
      if (const std::int32_t a = b.anchor[t]; a >= 0)  // keep the rest offset from the body parent
        w.translation = transform_point(tg[a], transform_point(inverse(tg0[a]), mat4_translation(tg0[t])));
      if (t == mover) w.translation = add(w.translation, shift);
      tg[t] = to_matrix(w);
      p.local[t] = to_transform(mul(inverse(parent), tg[t]));
    }
    out.frames.push_back(std::move(p));
  }
  return out;
}

bool is_ancestor(const Skeleton& s, std::int32_t a, std::int32_t j) {
  for (std::int32_t p = s.parents[j]; p >= 0; p = s.parents[p])
    if (p == a) return true;
  return false;
}

std::string side_of(const std::string& part) {
  return part.size() > 2 && part[part.size() - 2] == '.' ? part.substr(part.size() - 2) : "";
}
std::string base_of(const std::string& part) {
  std::string b = part.substr(0, part.size() - side_of(part).size());
  while (!b.empty() && std::isdigit(static_cast<unsigned char>(b.back()))) b.pop_back();
  return b;
}

// pelvis, spine1.., neck1.., head: the joints of the body's axis in order.
std::vector<std::int32_t> axis_of(const RigMapping& m) {
  std::vector<std::int32_t> a;
  if (const std::int32_t p = m.find("pelvis"); p >= 0) a.push_back(p);
  for (const char* base : {"spine", "neck"})
    for (int i = 1;; ++i) {
      const std::int32_t j = m.find(base + std::to_string(i));
      if (j < 0) break;
      a.push_back(j);
    }
  if (const std::int32_t h = m.find("head"); h >= 0) a.push_back(h);
  return a;
}

std::vector<std::int32_t> chain_of(const RigMapping& m, const char* base) {
  std::vector<std::int32_t> c;
  for (int i = 1;; ++i) {
    const std::int32_t j = m.find(base + std::to_string(i));
    if (j < 0) return c;
    c.push_back(j);
  }
}

std::string refusal(const std::string& what, const Skeleton& s, const RigMapping& m) {
  std::string missing;
  for (std::size_t i = 0; i < m.missing.size(); ++i) missing += (i ? ", " : "") + m.missing[i];
  return detail::cat(what, " is not a humanoid the retargeter can drive (convention: ", m.convention,
                     "): no joint maps to ", missing, "; joints not recognised: ", unmapped_joint_list(s, m),
                     "; name them with --alias JOINT=PART (PART: pelvis, spine, neck, head, clavicle.l, upperarm.l, "
                     "forearm.l, hand.l, thigh.l, shin.l, foot.l, toe.l, or .r; or a joint name of a known convention)");
}

}  // namespace

namespace {

const char* axis_name(const Vec3& v) {
  static const char* names[3][2] = {{"+X", "-X"}, {"+Y", "-Y"}, {"+Z", "-Z"}};
  for (int a = 0; a < 3; ++a)
    if (v[std::size_t(a)] != 0.0f) return names[a][v[std::size_t(a)] < 0.0f];
  return "?";
}

// The axis nearest `v` (a unit axis vector), among those with skip[a] unset.
Vec3 snap(const Vec3& v, const bool skip[3]) {
  int best = -1;
  for (int a = 0; a < 3; ++a)
    if (!skip[a] && (best < 0 || std::abs(v[std::size_t(a)]) > std::abs(v[std::size_t(best)]))) best = a;
  Vec3 out{0.0f, 0.0f, 0.0f};
  out[std::size_t(best)] = v[std::size_t(best)] < 0.0f ? -1.0f : 1.0f;
  return out;
}

}  // namespace

MotionRig map_motion_rig(const Skeleton& skeleton, const BoneAliases& aliases) {
  // Read where the retargeter reads the motion: its rest pose in the file's
  // world (a clip's character may bind in another space, e.g. Z-up
  // CesiumMan under a turned root node).
  Skeleton s = skeleton;
  {
    const std::vector<Mat4> g = global_transforms(skeleton, rest_pose(skeleton));
    try {
      for (std::int32_t j = 0; j < s.num_joints(); ++j) s.inverse_bind[j] = inverse(g[j]);
    } catch (const InvalidArgument&) {
      s.inverse_bind = skeleton.inverse_bind;  // a degenerate rest pose: the bind pose will do
    }
  }
  // Up along +Y, then the other five axis directions brought onto +Y.
  auto rot = [](Vec3 left, Vec3 up) {  // rows: left, up, forward = left x up
    const Vec3 f = {left[1] * up[2] - left[2] * up[1], left[2] * up[0] - left[0] * up[2], left[0] * up[1] - left[1] * up[0]};
    Mat4 m = mat4_identity();
    for (int c = 0; c < 3; ++c) {
      m[std::size_t(c * 4 + 0)] = left[std::size_t(c)];
      m[std::size_t(c * 4 + 1)] = up[std::size_t(c)];
      m[std::size_t(c * 4 + 2)] = f[std::size_t(c)];
    }
    return m;
  };
  const std::vector<std::pair<Vec3, Vec3>> tries = {{{1, 0, 0}, {0, 1, 0}}, {{1, 0, 0}, {0, 0, 1}}, {{0, 1, 0}, {1, 0, 0}},
                                                    {{1, 0, 0}, {0, 0, -1}}, {{-1, 0, 0}, {0, -1, 0}}, {{0, -1, 0}, {-1, 0, 0}}};
  for (const auto& [l0, u0] : tries) {
    const Mat4 w = rot(l0, u0);
    RigMapping m = map_rig(s, aliases, w);
    if (!m.humanoid()) continue;
    // Up: from the thighs to the upper arms; left: the left limbs' side.
    std::vector<Vec3> at(static_cast<std::size_t>(s.num_joints()));
    for (std::int32_t j = 0; j < s.num_joints(); ++j) at[j] = mat4_translation(inverse(s.inverse_bind[j]));
    auto p = [&](const char* part) { return at[m.find(part)]; };
    Vec3 up{}, left{};
    for (int c = 0; c < 3; ++c) {
      const std::size_t k = std::size_t(c);
      up[k] = p("upperarm.l")[k] + p("upperarm.r")[k] - p("thigh.l")[k] - p("thigh.r")[k];
      left[k] = p("upperarm.l")[k] + p("thigh.l")[k] - p("upperarm.r")[k] - p("thigh.r")[k];
    }
    const bool none[3] = {false, false, false};
    const Vec3 su = snap(up, none);
    bool skip[3] = {su[0] != 0.0f, su[1] != 0.0f, su[2] != 0.0f};
    const Vec3 sl = snap(left, skip);
    MotionRig r;
    r.to_world = rot(sl, su);
    const Vec3 fwd = {sl[1] * su[2] - sl[2] * su[1], sl[2] * su[0] - sl[0] * su[2], sl[0] * su[1] - sl[1] * su[0]};
    const std::string up_name = axis_name(su);
    r.frame = detail::cat(up_name[0] == '+' ? up_name.substr(1) : up_name, " up, facing ", axis_name(fwd));
    if (r.to_world != mat4_identity()) r.frame += " (turned to Y up, facing +Z)";
    r.mapping = r.to_world == w ? std::move(m) : map_rig(s, aliases, r.to_world);
    if (!r.mapping.humanoid()) r.mapping = map_rig(s, aliases, w);
    return r;
  }
  MotionRig r;
  r.mapping = map_rig(s, aliases);
  r.frame = "Y up, facing +Z (assumed: not a humanoid)";
  return r;
}

Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world, const RetargetMap& map) {
  const Skeleton& src = motion.skeleton;
  const std::int32_t J = target.num_joints();
  Binding b = unbound(J);
  for (const auto& [sn, tn] : map.pairs) {
    const std::int32_t s = src.find(sn), t = target.find(tn);
    if (s < 0 || t < 0) continue;
    b.source_of[t] = s;
    if (b.hips_t < 0) {
      b.hips_t = t;
      b.hips_s = s;
    }
  }
  GATCORE_CHECK(b.hips_t >= 0, motion.name, ": no joint of the motion maps onto the target skeleton");
  // Each mapped joint aims at its first mapped child.
  const auto tchildren = target.children();
  for (std::int32_t t = 0; t < J; ++t)
    for (std::int32_t c : tchildren[t])
      if (b.source_of[t] >= 0 && b.source_of[c] >= 0 && b.aim_t[t] < 0) {
        b.aim_t[t] = c;
        b.aim_s[t] = b.source_of[c];
      }
  return apply(motion, target, bind_to_world, b);
}

Clip retarget(const Motion& motion, const Skeleton& target, const Mat4& bind_to_world, const RetargetOptions& opt) {
  const Skeleton& src = motion.skeleton;
  const MotionRig mr = map_motion_rig(src, opt.source_aliases);
  const RigMapping& ms = mr.mapping;
  const RigMapping mt = map_rig(target, opt.target_aliases, bind_to_world);
  GATCORE_CHECK(ms.humanoid(), refusal(motion.name + ": the motion's skeleton", src, ms));
  const std::int32_t J = target.num_joints();
  Binding b = unbound(J);
  b.source_to_world = mr.to_world;
  b.hips_s = ms.find("pelvis");
  if (!mt.humanoid()) {
    if (!opt.root_motion_only) throw InvalidArgument(refusal(opt.target_name, target, mt));
    // Root motion only: the pelvis if there is one, else the root of the
    // largest joint tree.
    b.hips_t = mt.find("pelvis");
    if (b.hips_t < 0) {
      std::vector<int> size(static_cast<std::size_t>(J), 1);
      for (std::int32_t j = J - 1; j > 0; --j)
        if (target.parents[j] >= 0) size[target.parents[j]] += size[j];
      for (std::int32_t j = 0; j < J; ++j)
        if (target.parents[j] < 0 && (b.hips_t < 0 || size[j] > size[b.hips_t])) b.hips_t = j;
      b.by_height = true;
    }
    GATCORE_CHECK(b.hips_t >= 0, opt.target_name, ": the skeleton has no joints");
    return apply(motion, target, bind_to_world, b);
  }
  b.hips_t = mt.find("pelvis");
  // Pairs by body part; spine and neck chains of different lengths by
  // relative position: each target link takes the source link at the same
  // fraction of the chain. The spine's top goes onto the top (the chest
  // carries the arms); the neck's base onto the base (a one-link neck
  // follows the source's first neck link).
  for (const char* base : {"spine", "neck"}) {
    const auto tc = chain_of(mt, base), sc = chain_of(ms, base);
    if (tc.empty() || sc.empty()) continue;
    const double T = static_cast<double>(tc.size()), S = static_cast<double>(sc.size());
    const bool top = std::string(base) == "spine";
    for (std::size_t i = 0; i < tc.size(); ++i) {
      const double x = static_cast<double>(i);
      const long k = top ? std::lround((x + 1.0) * S / T) - 1 : static_cast<long>(std::floor(x * S / T));
      b.source_of[tc[i]] = sc[static_cast<std::size_t>(std::clamp<long>(k, 0, static_cast<long>(sc.size()) - 1))];
    }
  }
  for (std::int32_t t = 0; t < J; ++t) {
    if (mt.role[t] != JointRole::body) continue;
    const std::string& part = mt.body[t];
    const std::string base = base_of(part);
    if (base == "spine" || base == "neck") continue;
    b.source_of[t] = ms.find(part);
  }
  // Aims: along the axis, the next link of each side's own axis; along the
  // limbs, the next part both sides have.
  const auto taxis = axis_of(mt), saxis = axis_of(ms);
  auto next_on = [](const std::vector<std::int32_t>& axis, std::int32_t j) {
    const auto it = std::find(axis.begin(), axis.end(), j);
    return it == axis.end() || it + 1 == axis.end() ? -1 : *(it + 1);
  };
  for (std::int32_t t = 0; t < J; ++t) {
    const std::int32_t s = b.source_of[t];
    if (s < 0) continue;
    const std::string& part = mt.body[t];
    const std::string side = side_of(part), base = base_of(part);
    if (side.empty()) {
      b.aim_t[t] = next_on(taxis, t);
      b.aim_s[t] = next_on(saxis, s);
      continue;
    }
    std::vector<std::string> next;
    if (base == "clavicle") next = {"upperarm"};
    else if (base == "upperarm") next = {"forearm"};
    else if (base == "forearm") next = {"hand"};
    else if (base == "hand") next = {"middle1", "index1", "ring1", "pinky1"};
    else if (base == "thigh") next = {"shin"};
    else if (base == "shin") next = {"foot"};
    else if (base == "foot") next = {"toe"};
    else if (part.size() > side.size() && std::isdigit(static_cast<unsigned char>(part[part.size() - side.size() - 1])))
      next = {base + std::to_string(part[part.size() - side.size() - 1] - '0' + 1)};
    for (const std::string& n : next)
      if (mt.find(n + side) >= 0 && ms.find(n + side) >= 0) {
        b.aim_t[t] = mt.find(n + side);
        b.aim_s[t] = ms.find(n + side);
        break;
      }
    // A limb joint that does not hang under its body parent (an IK foot on
    // the root) keeps its rest offset from that parent.
    std::string parent;
    if (base == "upperarm") parent = "clavicle";
    else if (base == "forearm") parent = "upperarm";
    else if (base == "hand") parent = "forearm";
    else if (base == "shin") parent = "thigh";
    else if (base == "foot") parent = "shin";
    else if (base == "toe") parent = "foot";
    // Thighs hang off the pelvis: rigs whose legs sit on a root above the
    // hips (the Quaternius women: Root -> Hips, Root -> UpperLeg.L) would
    // otherwise keep the legs at their rest places beside an unturned root
    // while the pelvis turns (a character turned round had its left leg at
    // its right hip).
    const std::int32_t a = base == "thigh" ? mt.find("pelvis") : parent.empty() ? -1 : mt.find(parent + side);
    if (a >= 0 && !is_ancestor(target, a, t) && !is_ancestor(target, t, a)) b.anchor[t] = a;
  }
  return apply(motion, target, bind_to_world, b);
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
