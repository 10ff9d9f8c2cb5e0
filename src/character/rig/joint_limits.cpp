// Per-joint rotation limit tables (JSON through nlohmann-json).
#include "gatcore/character/rig/joint_limits.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <optional>
#include <sstream>
#include <utility>

#include <nlohmann/json.hpp>

#include "gatcore/character/rig/bone_axis.hpp"
#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/character/rig/vec3.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

JointLimit deg(float xlo, float xhi, float ylo, float yhi, float zlo, float zhi) {
  JointLimit l;
  l.lo = {xlo, ylo, zlo};
  l.hi = {xhi, yhi, zhi};
  return l;
}

constexpr const char* kAxes[3] = {"x", "y", "z"};

// [lo, hi] in degrees within [-180, 180], lo <= hi; errors name the field.
std::pair<float, float> parse_range(const nlohmann::json& r, const std::string& source, const std::string& field,
                                    const char* expected) {
  GATCORE_CHECK(r.is_array() && r.size() == 2 && r[0].is_number() && r[1].is_number(), source, ": ", field,
                ": expected ", expected, ", got ", r.dump());
  const double lo = r[0].get<double>(), hi = r[1].get<double>();
  GATCORE_CHECK(std::isfinite(lo) && std::isfinite(hi) && lo >= -180.0 && hi <= 180.0, source, ": ", field,
                ": angles must be finite degrees in [-180, 180], got ", r.dump());
  GATCORE_CHECK(lo <= hi, source, ": ", field, ": min ", lo, " is above max ", hi);
  return {static_cast<float>(lo), static_cast<float>(hi)};
}

// One limit object {"x": [lo, hi], ...}; absent axes are fixed at 0.
JointLimit parse_limit(const nlohmann::json& j, const std::string& source, const std::string& where) {
  GATCORE_CHECK(j.is_object(), source, ": ", where, ": expected an object with \"x\", \"y\", \"z\" ranges, got ",
                j.dump());
  JointLimit l;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    GATCORE_CHECK(k == "x" || k == "y" || k == "z" || k == "match" || (k == "flex" && where != "default"), source,
                  ": ", where, ": unknown field \"", k, "\"");
  }
  for (int a = 0; a < 3; ++a) {
    if (!j.contains(kAxes[a])) continue;
    const auto [lo, hi] = parse_range(j.at(kAxes[a]), source, where + "." + kAxes[a], "[min, max] in degrees");
    l.lo[a] = lo;
    l.hi[a] = hi;
  }
  return l;
}

// "flex": [lo, hi] of a joint rule.
FlexionRange parse_flex(const nlohmann::json& j, const std::string& source, const std::string& where) {
  FlexionRange f;
  if (!j.contains("flex")) return f;
  const auto [lo, hi] = parse_range(j.at("flex"), source, where + ".flex", "[min, max] flexion in degrees");
  f.enabled = true;
  f.lo = lo;
  f.hi = hi;
  return f;
}

nlohmann::json limit_json(const JointLimit& l) {
  nlohmann::json j = nlohmann::json::object();
  for (int a = 0; a < 3; ++a) j[kAxes[a]] = {l.lo[a], l.hi[a]};
  return j;
}

}  // namespace

bool glob_match(const std::string& p, const std::string& s) {
  // Iterative matcher with backtracking to the last '*'.
  std::size_t i = 0, j = 0, star = std::string::npos, mark = 0;
  while (j < s.size()) {
    if (i < p.size() && (p[i] == '?' || p[i] == s[j])) {
      ++i, ++j;
    } else if (i < p.size() && p[i] == '*') {
      star = i++;
      mark = j;
    } else if (star != std::string::npos) {
      i = star + 1;
      j = ++mark;
    } else {
      return false;
    }
  }
  while (i < p.size() && p[i] == '*') ++i;
  return i == p.size();
}

JointLimitTable JointLimitTable::default_humanoid() {
  // Degrees. Bones run along local +Y (Blender / FBX2glTF convention), so Y is
  // the twist about the bone; X is flexion / extension and Z abduction for
  // most joints. Hinges bend one way only, in the direction measured on the
  // Quaternius rigs (test_character_joint_limits checks that knee flexion
  // moves the ankle backwards, elbow flexion the wrist forwards, and that
  // the upper-arm range reaches arms-down).
  JointLimitTable t;
  t.name = "humanoid";
  t.fallback_degrees = deg(-10, 10, -10, 10, -10, 10);
  auto add = [&](const char* pattern, JointLimit l) { t.rules.push_back({pattern, l, {}}); };
  add("hips", deg(-10, 10, -15, 15, -8, 8));
  add("abdomen", deg(-15, 20, -15, 15, -10, 10));
  add("torso", deg(-10, 15, -15, 15, -10, 10));
  add("chest", deg(-10, 15, -15, 15, -10, 10));
  add("spine*", deg(-15, 20, -15, 15, -10, 10));
  add("neck*", deg(-20, 25, -30, 30, -15, 15));
  add("head", deg(-20, 25, -40, 40, -15, 15));
  add("shoulder.*", deg(-10, 10, -5, 5, -12, 12));
  add("clavicle.*", deg(-10, 10, -5, 5, -12, 12));
  // The Quaternius rest pose is a T-pose: upper-arm X lowers / raises the arm
  // (-90 = hanging at the side, where walking and most animation keep it;
  // both sides alike), Z swings it forwards / backwards.
  add("upperarm.*", deg(-90, 30, -40, 40, -50, 50));
  // Elbows bend about local Z on these rigs, in mirrored directions (the
  // forearm swings forwards); forearm twist about Y.
  add("lowerarm.l", deg(-5, 5, -40, 40, -130, 0));
  add("lowerarm.r", deg(-5, 5, -40, 40, 0, 130));
  add("hand.*", deg(-40, 40, -15, 15, -30, 30));
  add("thumb*", deg(-15, 15, -10, 10, -15, 15));
  add("index*", deg(-10, 40, -3, 3, -5, 5));
  add("middle*", deg(-10, 40, -3, 3, -5, 5));
  add("ring*", deg(-10, 40, -3, 3, -5, 5));
  add("pinky*", deg(-10, 40, -3, 3, -5, 5));
  // Hips: the men's rigs flex about Z (mirrored) and abduct about X, the
  // women's the other way round, so both axes get the flexion range.
  add("upperleg.*", deg(-45, 45, -20, 20, -45, 45));
  add("lowerleg.*", deg(0, 120, -5, 5, -3, 3));  // knees: +X moves the ankle backwards
  add("foot.*", deg(-25, 25, -10, 10, -10, 10));
  add("toe*", deg(-20, 30, -3, 3, -3, 3));
  return t;
}

namespace {

// What flexion_axis reads of a skeleton, once per skeleton: the bind pose's
// joint-to-world matrices and the character's front (where the foot* joints'
// bones point: to the toes, or along the rig's bone axis for feet without
// toes, summed; zero when there are no feet).
struct BindFront {
  std::vector<Mat4> g;
  Vec3 front{0.0f, 0.0f, 0.0f};
};

BindFront bind_front(const Skeleton& s) {
  BindFront b{global_transforms(s, bind_pose(s)), {0.0f, 0.0f, 0.0f}};
  const BoneAxis conv = bone_axis_convention(s);
  for (std::int32_t f = 0; f < s.num_joints(); ++f) {
    if (normalise_bone_name(s.names[std::size_t(f)]).rfind("foot", 0) != 0) continue;
    const Vec3 d = bone_direction(s, f, conv);
    for (int k = 0; k < 3; ++k) b.front[std::size_t(k)] += d[std::size_t(k)];
  }
  const float fl = std::sqrt(dot(b.front, b.front));
  if (!(fl > 1e-3f)) return {b.g, {0.0f, 0.0f, 0.0f}};
  for (float& v : b.front) v /= fl;
  return b;
}

FlexionAxis flexion_axis(const Skeleton& s, const BindFront& b, std::int32_t j) {
  if (dot(b.front, b.front) == 0.0f) return {};
  std::int32_t child = -1;
  for (std::int32_t c = 0; c < s.num_joints() && child < 0; ++c)
    if (s.parents[std::size_t(c)] == j) child = c;
  if (child < 0) return {};
  const Mat4& m = b.g[std::size_t(j)];
  const Vec3 bone = sub(mat4_translation(b.g[std::size_t(child)]), mat4_translation(m));
  const float bl = std::sqrt(dot(bone, bone));
  if (!(bl > 0.0f)) return {};
  FlexionAxis best;
  float best_score = 0.5f;  // per radian, in bone lengths: below that the axis mostly swings the child sideways
  for (int a : {0, 2}) {
    Vec3 axis{m[std::size_t(a * 4)], m[std::size_t(a * 4 + 1)], m[std::size_t(a * 4 + 2)]};
    const float al = std::sqrt(dot(axis, axis));
    if (!(al > 0.0f)) continue;
    for (float& v : axis) v /= al;
    const float score = dot(cross(axis, bone), b.front) / bl;  // the child's speed to the front per radian
    if (std::fabs(score) > best_score) {
      best_score = std::fabs(score);
      best = {a, score > 0.0f ? 1 : -1};
    }
  }
  return best;
}

}  // namespace

std::vector<JointLimit> JointLimitTable::limits_for(const Skeleton& s, std::vector<std::string>* matched) const {
  constexpr float r = std::numbers::pi_v<float> / 180.0f;
  std::vector<JointLimit> out(static_cast<std::size_t>(s.num_joints()));
  if (matched) matched->assign(out.size(), "");
  std::optional<BindFront> bind;  // for flexion ranges, read once
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    if (s.parents[j] < 0) {
      if (matched) (*matched)[j] = "(root: rest)";
      continue;
    }
    const std::string n = normalise_bone_name(s.names[j]);
    const JointLimit* l = &fallback_degrees;
    const FlexionRange* flex = nullptr;
    std::string which = "(default)";
    for (const auto& rule : rules)
      if (glob_match(rule.pattern, n)) {
        l = &rule.degrees;
        flex = &rule.flex;
        which = rule.pattern;
        break;
      }
    for (int a = 0; a < 3; ++a) {
      out[j].lo[a] = l->lo[a] * r;
      out[j].hi[a] = l->hi[a] * r;
    }
    if (flex && flex->enabled) {
      if (!bind) bind = bind_front(s);
      const FlexionAxis f = flexion_axis(s, *bind, j);
      if (f.axis >= 0) {
        const auto a = std::size_t(f.axis);
        out[j].lo[a] = (f.sign > 0 ? flex->lo : -flex->hi) * r;
        out[j].hi[a] = (f.sign > 0 ? flex->hi : -flex->lo) * r;
        which += f.axis == 0 ? (f.sign > 0 ? " (flex +x)" : " (flex -x)") : (f.sign > 0 ? " (flex +z)" : " (flex -z)");
      } else {
        which += " (no flexion axis: x/y/z ranges)";
      }
    }
    if (matched) (*matched)[j] = which;
  }
  return out;
}

FlexionAxis flexion_axis(const Skeleton& s, std::int32_t j, Vec3* front_out) {
  GATCORE_CHECK(j >= 0 && j < s.num_joints(), "flexion_axis: joint ", j, " of ", s.num_joints());
  const BindFront b = bind_front(s);
  if (front_out && dot(b.front, b.front) > 0.0f) *front_out = b.front;
  return flexion_axis(s, b, j);
}

JointLimitTable parse_joint_limits(const std::string& text, const std::string& source) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    throw InvalidArgument(detail::cat(source, ": not a JSON joint-limit table: ", e.what()));
  }
  GATCORE_CHECK(j.is_object(), source, ": expected a JSON object");
  GATCORE_CHECK(j.contains("format") && j.at("format") == "gatcore-joint-limits", source,
                ": field \"format\" must be \"gatcore-joint-limits\", got ",
                j.contains("format") ? j.at("format").dump() : std::string("nothing"));
  GATCORE_CHECK(j.contains("version") && j.at("version") == 1, source, ": field \"version\": unsupported value ",
                j.contains("version") ? j.at("version").dump() : std::string("(missing)"), " (expected 1)");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    GATCORE_CHECK(k == "format" || k == "version" || k == "name" || k == "default" || k == "joints", source,
                  ": unknown field \"", k, "\"");
  }
  JointLimitTable t;
  t.name = source;
  if (j.contains("name")) {
    GATCORE_CHECK(j.at("name").is_string(), source, ": field \"name\": expected a string, got ", j.at("name").dump());
    t.name = j.at("name").get<std::string>();
  }
  GATCORE_CHECK(j.contains("default"), source, ": missing field \"default\" (limits for joints no rule matches)");
  t.fallback_degrees = parse_limit(j.at("default"), source, "default");
  if (j.contains("joints")) {
    const nlohmann::json& js = j.at("joints");
    GATCORE_CHECK(js.is_array(), source, ": field \"joints\": expected an array, got ", js.dump());
    for (std::size_t i = 0; i < js.size(); ++i) {
      const std::string where = "joints[" + std::to_string(i) + "]";
      GATCORE_CHECK(js[i].is_object() && js[i].contains("match") && js[i].at("match").is_string() &&
                        !js[i].at("match").get<std::string>().empty(),
                    source, ": ", where, ".match: expected a non-empty name pattern, got ",
                    js[i].is_object() && js[i].contains("match") ? js[i].at("match").dump() : std::string("nothing"));
      t.rules.push_back({js[i].at("match").get<std::string>(), parse_limit(js[i], source, where),
                         parse_flex(js[i], source, where)});
    }
  }
  return t;
}

JointLimitTable load_joint_limits(const std::string& path) {
  if (path == "humanoid") return JointLimitTable::default_humanoid();
  std::ifstream f(path);
  GATCORE_CHECK(f.good(), path, ": cannot open the joint-limit table");
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_joint_limits(ss.str(), path);
}

std::string joint_limits_json(const JointLimitTable& t) {
  nlohmann::json j;
  j["format"] = "gatcore-joint-limits";
  j["version"] = 1;
  j["name"] = t.name;
  j["default"] = limit_json(t.fallback_degrees);
  j["joints"] = nlohmann::json::array();
  for (const auto& r : t.rules) {
    nlohmann::json e = limit_json(r.degrees);
    e["match"] = r.pattern;
    if (r.flex.enabled) e["flex"] = {r.flex.lo, r.flex.hi};
    j["joints"].push_back(e);
  }
  return j.dump(2);
}

LimitExcess pose_limit_excess(const Skeleton& s, const Pose& rest, const Pose& pose,
                              const std::vector<JointLimit>& limits, std::int32_t orientation_joint) {
  const std::int32_t J = s.num_joints();
  GATCORE_CHECK(static_cast<std::int32_t>(limits.size()) == J && static_cast<std::int32_t>(rest.local.size()) == J &&
                    static_cast<std::int32_t>(pose.local.size()) == J,
                "pose_limit_excess: ", limits.size(), " limits, ", rest.local.size(), " rest and ", pose.local.size(),
                " posed transforms for ", J, " joints");
  std::vector<char> skip(static_cast<std::size_t>(J), 0);
  for (std::int32_t j = orientation_joint; j >= 0 && j < J; j = s.parents[std::size_t(j)]) skip[std::size_t(j)] = 1;
  // A joint hanging off an ancestor of the orientation joint instead of
  // under it (the Quaternius women's thighs on Root, beside Hips) is measured
  // against the orientation joint: its rotation relative to Root carries the
  // character's turning, which is not the joint's own (a turned-round body
  // read as thighs 130 degrees outside their limits).
  std::vector<Mat4> g, g0;
  if (orientation_joint >= 0 && orientation_joint < J) {
    g = global_transforms(s, pose);
    g0 = global_transforms(s, rest);
  }
  auto rot = [](const Mat4& m) { return to_transform(m).rotation; };
  auto inv = [](const Quat& q) { return Quat{-q[0], -q[1], -q[2], q[3]}; };
  LimitExcess worst;
  for (std::int32_t j = 0; j < J; ++j) {
    if (s.parents[std::size_t(j)] < 0 || skip[std::size_t(j)]) continue;  // roots carry the motion's root movement
    const Quat& r = rest.local[std::size_t(j)].rotation;
    Quat q = quat_normalize(quat_mul(inv(r), pose.local[std::size_t(j)].rotation));
    if (!g.empty() && skip[std::size_t(s.parents[std::size_t(j)])]) {
      const auto o = std::size_t(orientation_joint);
      const Quat a = quat_mul(inv(rot(g0[o])), rot(g0[std::size_t(j)]));
      const Quat b = quat_mul(inv(rot(g[o])), rot(g[std::size_t(j)]));
      q = quat_normalize(quat_mul(inv(a), b));
    }
    // Rotation matrix of q; R = Rx(a) Ry(b) Rz(c): R02 = sin b, a = atan2(-R12, R22), c = atan2(-R01, R00).
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double r00 = 1 - 2 * (y * y + z * z), r01 = 2 * (x * y - z * w), r02 = 2 * (x * z + y * w);
    const double r12 = 2 * (y * z - x * w), r22 = 1 - 2 * (x * x + y * y);
    const double ang[3] = {std::atan2(-r12, r22), std::asin(std::clamp(r02, -1.0, 1.0)), std::atan2(-r01, r00)};
    for (int a = 0; a < 3; ++a) {
      const double lo = limits[std::size_t(j)].lo[std::size_t(a)], hi = limits[std::size_t(j)].hi[std::size_t(a)];
      const double e = std::max({0.0, lo - ang[a], ang[a] - hi});
      if (e > worst.radians) worst = {float(e), j, a};
    }
  }
  return worst;
}

}  // namespace gatcore::character
