#pragma once
// Skeletons in the joint-naming conventions users bring, written from code
// (names, hierarchy, rest pose: T or A, bone-axis style, units), so the rig
// tests need no downloaded data. Every rig is built on one body (a 1.8 m
// figure standing at y = 0, facing +Z, its left at +X), so a pose moved onto
// any of them should land its hands and feet where the source's are, after
// scaling by hip height.
//   rigfix::specs()          every convention's rig
//   rigfix::skeleton(spec)   the rig as a Skeleton (bind = rest)
//   rigfix::character(spec)  the rig with a box per bone, for glTF files
//   rigfix::bvh(spec, pose)  the rig as a BVH with frames of a known pose
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "gatcore/character/rig/character.hpp"
#include "gatcore/character/rig/pose.hpp"

namespace rigfix {

using gatcore::character::Mat4;
using gatcore::character::Quat;
using gatcore::character::Vec3;

enum class Axes { identity, y_along_bone, x_along_bone };

struct Joint {
  std::string name;    // '<' -> the rig's side token
  std::string parent;  // "" for a root
  std::string where;   // a landmark (see landmark())
};

struct Spec {
  std::string id;          // short name for test output
  std::string convention;  // what map_rig should report (a prefix of it)
  std::string left, right; // side tokens
  bool a_pose = false;
  Axes axes = Axes::identity;
  float units = 1.0f;      // metres -> file units
  std::string prefix;      // namespace prefix on every name ("mixamorig:")
  std::vector<Joint> joints;
  bool humanoid = true;
};

// Landmarks of the common body, left side (x > 0); ".R" landmarks mirror x.
inline Vec3 landmark(const std::string& w, bool a_pose) {
  const bool right = w.size() > 2 && w.substr(w.size() - 2) == ".R";
  const std::string k = right || (w.size() > 2 && w.substr(w.size() - 2) == ".L") ? w.substr(0, w.size() - 2) : w;
  Vec3 p{0.0f, 0.0f, 0.0f};
  bool arm = false;
  auto frac = [&](const std::string& s, float& a, float& b) {  // "spine:2/3"
    const auto c = s.find(':'), sl = s.find('/');
    a = std::stof(s.substr(c + 1, sl - c - 1));
    b = std::stof(s.substr(sl + 1));
  };
  static const std::map<std::string, Vec3> fixed = {
      {"root", {0.0f, 0.0f, 0.0f}},        {"pelvis", {0.0f, 1.0f, 0.0f}},    {"head", {0.0f, 1.62f, 0.0f}},
      {"headtop", {0.0f, 1.8f, 0.0f}},     {"clavicle", {0.03f, 1.42f, 0.0f}}, {"upperarm", {0.17f, 1.45f, 0.0f}},
      {"forearm", {0.45f, 1.45f, 0.0f}},   {"hand", {0.71f, 1.45f, 0.0f}},    {"thigh", {0.1f, 0.95f, 0.0f}},
      {"shin", {0.1f, 0.52f, 0.0f}},       {"foot", {0.1f, 0.08f, 0.0f}},     {"toe", {0.1f, 0.02f, 0.13f}},
      {"toeend", {0.1f, 0.02f, 0.2f}},     {"pole", {0.1f, 0.52f, 0.5f}},     {"heel", {0.1f, 0.0f, -0.05f}},
      {"chestside", {0.08f, 1.35f, 0.08f}}, {"hipside", {0.08f, 1.0f, 0.0f}}};
  if (auto it = fixed.find(k); it != fixed.end()) {
    p = it->second;
    arm = k == "forearm" || k == "hand";
  } else if (k.rfind("spine:", 0) == 0) {  // from the pelvis up to the chest at 1.42
    float a, b;
    frac(k, a, b);
    p = {0.0f, 1.0f + 0.42f * a / b, 0.0f};
  } else if (k.rfind("neck:", 0) == 0) {  // 1.50 .. 1.58
    float a, b;
    frac(k, a, b);
    p = {0.0f, 1.5f + 0.1f * (a - 1.0f) / b, 0.0f};
  } else if (k.rfind("mid:", 0) == 0) {  // "mid:upperarm:forearm" (twist segments)
    const auto c = k.find(':', 4);
    const Vec3 a = landmark(k.substr(4, c - 4), false), b = landmark(k.substr(c + 1), false);
    p = {0.5f * (a[0] + b[0]), 0.5f * (a[1] + b[1]), 0.5f * (a[2] + b[2])};
    arm = k.find("arm") != std::string::npos || k.find("hand") != std::string::npos;
  } else if (k.rfind("finger:", 0) == 0) {  // "finger:index:2" (0 = metacarpal, 4 = tip end)
    const auto c = k.find(':', 7);
    const std::string f = k.substr(7, c - 7);
    const int n = std::stoi(k.substr(c + 1));
    const float z = f == "thumb" ? 0.05f : f == "index" ? 0.03f : f == "middle" ? 0.0f : f == "ring" ? -0.02f : -0.04f;
    p = n == 0 ? Vec3{0.75f, 1.45f, z * 0.5f}
               : f == "thumb" ? Vec3{0.73f + 0.03f * n, 1.43f, 0.02f + 0.02f * n} : Vec3{0.77f + 0.03f * n, 1.45f, z};
    arm = true;
  } else if (k.rfind("at:", 0) == 0) {  // "at:x,y,z"
    std::sscanf(k.c_str() + 3, "%f,%f,%f", &p[0], &p[1], &p[2]);
  } else {
    std::fprintf(stderr, "rigfix: unknown landmark %s\n", w.c_str());
    std::abort();
  }
  if (arm && a_pose) {  // arms 45 degrees down about the shoulder
    const Vec3 s = landmark("upperarm", false);
    const float c = std::cos(0.7853982f), sn = std::sin(0.7853982f);
    const float dx = p[0] - s[0], dy = p[1] - s[1];
    p = {s[0] + c * dx + sn * dy, s[1] - sn * dx + c * dy, p[2]};
  }
  if (right) p[0] = -p[0];
  return p;
}

// Expands '<' in names and "<" in landmarks to both sides.
struct Expanded {
  std::vector<std::string> names;
  std::vector<std::int32_t> parents;
  std::vector<Vec3> pos;  // metres
};

inline Expanded expand(const Spec& s) {
  Expanded e;
  std::map<std::string, std::int32_t> index;
  auto side = [](std::string x, const std::string& tok) {
    for (std::size_t i; (i = x.find('<')) != std::string::npos;) x.replace(i, 1, tok);
    return x;
  };
  for (const Joint& j : s.joints) {
    const bool sided = j.name.find('<') != std::string::npos;
    for (int k = 0; k < (sided ? 2 : 1); ++k) {
      const std::string tok = k == 0 ? s.left : s.right, lm = k == 0 ? ".L" : ".R";
      const std::string name = s.prefix + side(j.name, tok);
      std::int32_t parent = -1;
      if (!j.parent.empty()) {
        const auto it = index.find(s.prefix + side(j.parent, tok));
        if (it == index.end()) {
          std::fprintf(stderr, "rigfix %s: joint %s has unknown parent %s\n", s.id.c_str(), name.c_str(), j.parent.c_str());
          std::abort();
        }
        parent = it->second;
      }
      index[name] = static_cast<std::int32_t>(e.names.size());
      e.names.push_back(name);
      e.parents.push_back(parent);
      std::string where = j.where;
      const bool lsided = where.find('<') != std::string::npos;
      for (std::size_t i; (i = where.find('<')) != std::string::npos;) where.erase(i, 1);
      e.pos.push_back(landmark(lsided ? where + lm : where, s.a_pose));
    }
  }
  return e;
}

inline Quat rotation_between(Vec3 a, Vec3 b) {
  auto norm = [](Vec3& v) {
    const float l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (float& x : v) x /= l;
  };
  norm(a);
  norm(b);
  const float d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  if (d < -0.9999f) return {0.0f, 0.0f, 1.0f, 0.0f};
  Quat q{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0], 1.0f + d};
  return gatcore::character::quat_normalize(q);
}

// Bind = rest. Bone axes: identity (BVH, Mixamo), +Y along the bone to the
// first child (Blender), or +X along it (Maya, Max, Unreal, Daz).
inline gatcore::character::Skeleton skeleton(const Spec& s) {
  using namespace gatcore::character;
  const Expanded e = expand(s);
  const std::size_t J = e.names.size();
  std::vector<Mat4> world(J);
  std::vector<std::int32_t> first_child(J, -1);
  for (std::size_t j = 0; j < J; ++j)
    if (e.parents[j] >= 0 && first_child[e.parents[j]] < 0) first_child[e.parents[j]] = static_cast<std::int32_t>(j);
  for (std::size_t j = 0; j < J; ++j) {
    Transform t;
    t.translation = {e.pos[j][0] * s.units, e.pos[j][1] * s.units, e.pos[j][2] * s.units};
    const std::int32_t c = first_child[j];
    if (s.axes != Axes::identity && c >= 0) {
      const Vec3 d{e.pos[c][0] - e.pos[j][0], e.pos[c][1] - e.pos[j][1], e.pos[c][2] - e.pos[j][2]};
      if (std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]) > 1e-6f)
        t.rotation = rotation_between(s.axes == Axes::y_along_bone ? Vec3{0, 1, 0} : Vec3{1, 0, 0}, d);
    }
    world[j] = to_matrix(t);
  }
  Skeleton sk;
  sk.names = e.names;
  sk.parents = e.parents;
  for (std::size_t j = 0; j < J; ++j) {
    sk.rest_local.push_back(to_transform(e.parents[j] >= 0 ? mul(inverse(world[e.parents[j]]), world[j]) : world[j]));
    sk.inverse_bind.push_back(inverse(world[j]));
    sk.root_parent.push_back(mat4_identity());
  }
  sk.validate(s.id.c_str());
  return sk;
}

// A box around each bone (to its first child, or a small cube at a leaf),
// weighted fully to the bone: enough of a mesh for a glTF round trip.
inline gatcore::character::Character character(const Spec& s) {
  using namespace gatcore::character;
  Character ch;
  ch.name = s.id + ".glb";
  ch.skeleton = skeleton(s);
  const Expanded e = expand(s);
  const std::size_t J = e.names.size();
  std::vector<std::int32_t> first_child(J, -1);
  for (std::size_t j = 0; j < J; ++j)
    if (e.parents[j] >= 0 && first_child[e.parents[j]] < 0) first_child[e.parents[j]] = static_cast<std::int32_t>(j);
  Mesh& m = ch.mesh;
  for (std::size_t j = 0; j < J; ++j) {
    const Vec3 a = e.pos[j], b = first_child[j] >= 0 ? e.pos[first_child[j]] : Vec3{a[0], a[1] + 0.02f, a[2]};
    const float r = 0.02f;
    const std::int32_t base = static_cast<std::int32_t>(m.num_vertices());
    for (int c = 0; c < 8; ++c) {
      const Vec3& end = (c & 4) ? b : a;
      m.positions.push_back((end[0] + ((c & 1) ? r : -r)) * s.units);
      m.positions.push_back((end[1] + ((c & 4) ? 0.0f : 0.0f)) * s.units + ((c & 2) ? r : -r) * s.units * 0.5f);
      m.positions.push_back((end[2] + ((c & 2) ? r : -r)) * s.units);
      m.weights.joint.push_back(static_cast<std::int32_t>(j));
      m.weights.weight.push_back(1.0f);
      m.weights.ptr.push_back(static_cast<std::int64_t>(m.weights.joint.size()));
    }
    static const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (const auto& q : quads)
      for (int t : {q[0], q[1], q[2], q[0], q[2], q[3]}) m.triangles.push_back(base + t);
  }
  ch.welded_from_file.resize(static_cast<std::size_t>(m.num_vertices()));
  for (std::size_t v = 0; v < ch.welded_from_file.size(); ++v) ch.welded_from_file[v] = static_cast<std::int32_t>(v);
  ch.joint_nodes.assign(J, -1);
  return ch;
}

// A pose on body parts: local Euler angles (degrees, applied Z then X then Y
// as the BVH channels below) for the joint the spec maps to each part, and a
// root translation (metres) per frame.
struct PartPose {
  std::map<std::string, Vec3> zxy;  // part (landmark name, e.g. "shin.L") -> degrees
  Vec3 move{0.0f, 0.0f, 0.0f};
};

// BVH joint names are the rest of their line: Biped's "Bip01 L Thigh" keeps
// its spaces (io/bvh.cpp).
inline std::string bvh_name(std::string n) { return n; }

// The rig as BVH (offsets in file units, every joint ZXY rotation channels,
// the roots also positions), frame 0 the rest pose, then one frame per pose.
// A pose's part angles go on the joint whose landmark is that part.
// Each joint's landmark, sided ("shin.L"), in expand() order: what a pose's parts name.
inline std::vector<std::string> joint_parts(const Spec& s) {
  std::vector<std::string> part;
  for (const Joint& jt : s.joints) {
    const bool sided = jt.name.find('<') != std::string::npos;
    for (int k = 0; k < (sided ? 2 : 1); ++k) {
      std::string w = jt.where;
      const bool ls = w.find('<') != std::string::npos;
      for (std::size_t i; (i = w.find('<')) != std::string::npos;) w.erase(i, 1);
      part.push_back(ls ? w + (k == 0 ? ".L" : ".R") : w);
    }
  }
  return part;
}

inline std::string bvh(const Spec& s, const std::vector<PartPose>& poses) {
  const Expanded e = expand(s);
  const std::size_t J = e.names.size();
  const std::vector<std::string> part = joint_parts(s);
  std::vector<std::vector<std::size_t>> kids(J);
  for (std::size_t j = 0; j < J; ++j)
    if (e.parents[j] >= 0) kids[e.parents[j]].push_back(j);
  std::ostringstream o;
  o << "HIERARCHY\n";
  std::vector<std::size_t> order;
  auto emit = [&](auto&& self, std::size_t j, int depth) -> void {
    const std::string ind(static_cast<std::size_t>(depth) * 2, ' ');
    const Vec3 off = e.parents[j] >= 0 ? Vec3{e.pos[j][0] - e.pos[e.parents[j]][0], e.pos[j][1] - e.pos[e.parents[j]][1],
                                              e.pos[j][2] - e.pos[e.parents[j]][2]}
                                       : e.pos[j];
    o << ind << (e.parents[j] < 0 ? "ROOT " : "JOINT ") << bvh_name(e.names[j]) << "\n" << ind << "{\n";
    o << ind << "  OFFSET " << off[0] * s.units << " " << off[1] * s.units << " " << off[2] * s.units << "\n";
    o << ind << "  CHANNELS " << (e.parents[j] < 0 ? "6 Xposition Yposition Zposition " : "3 ")
      << "Zrotation Xrotation Yrotation\n";
    order.push_back(j);
    for (std::size_t c : kids[j]) self(self, c, depth + 1);
    if (kids[j].empty())
      o << ind << "  End Site\n" << ind << "  {\n" << ind << "    OFFSET 0 " << 0.03f * s.units << " 0\n" << ind << "  }\n";
    o << ind << "}\n";
  };
  for (std::size_t j = 0; j < J; ++j)
    if (e.parents[j] < 0) emit(emit, j, 0);
  o << "MOTION\nFrames: " << poses.size() + 1 << "\nFrame Time: 0.0333333\n";
  for (std::size_t f = 0; f <= poses.size(); ++f) {
    for (std::size_t j : order) {
      if (e.parents[j] < 0) {
        const Vec3 mv = f > 0 ? poses[f - 1].move : Vec3{0, 0, 0};
        o << (e.pos[j][0] + mv[0]) * s.units << " " << (e.pos[j][1] + mv[1]) * s.units << " "
          << (e.pos[j][2] + mv[2]) * s.units << " ";
      }
      Vec3 a{0, 0, 0};
      if (f > 0)
        if (auto it = poses[f - 1].zxy.find(part[j]); it != poses[f - 1].zxy.end()) a = it->second;
      o << a[0] << " " << a[1] << " " << a[2] << " ";
    }
    o << "\n";
  }
  return o.str();
}

// Every tested convention. Parents are listed before children.
inline std::vector<Spec> specs() {
  std::vector<Spec> v;
  const std::vector<std::string> fingers = {"thumb", "index", "middle", "ring", "pinky"};
  {  // Quaternius Ultimate Modular (men): Root, Hips, Abdomen, Torso, Chest; fingers 2..4, thumb 2..3.
    Spec s{"quaternius", "Quaternius", "L", "R", false, Axes::y_along_bone, 1.0f, "", {}};
    s.joints = {{"Root", "", "root"},           {"Hips", "Root", "pelvis"},          {"Abdomen", "Hips", "spine:1/3"},
                {"Torso", "Abdomen", "spine:2/3"}, {"Chest", "Torso", "spine:3/3"},   {"Neck", "Chest", "neck:1/1"},
                {"Head", "Neck", "head"},       {"Shoulder.<", "Chest", "clavicle<"}, {"UpperArm.<", "Shoulder.<", "upperarm<"},
                {"LowerArm.<", "UpperArm.<", "forearm<"}, {"Hand.<", "LowerArm.<", "hand<"}};
    for (const char* f : {"Index", "Middle", "Ring", "Pinky"})
      for (int k = 2; k <= 4; ++k)
        s.joints.push_back({std::string(f) + std::to_string(k) + ".<",
                            k == 2 ? "Hand.<" : std::string(f) + std::to_string(k - 1) + ".<",
                            "finger:" + [&] { std::string l = f; for (char& c : l) c = static_cast<char>(std::tolower(c)); return l; }() + ":" + std::to_string(k - 1) + "<"});
    s.joints.push_back({"Thumb2.<", "Hand.<", "finger:thumb:1<"});
    s.joints.push_back({"Thumb3.<", "Thumb2.<", "finger:thumb:2<"});
    for (const Joint& j : std::vector<Joint>{{"UpperLeg.<", "Root", "thigh<"}, {"LowerLeg.<", "UpperLeg.<", "shin<"},
                                             {"Foot.<", "LowerLeg.<", "foot<"}})
      s.joints.push_back(j);
    v.push_back(s);
  }
  {  // Older Quaternius packs: the feet hang off the root (IK), pole targets.
    Spec s{"quaternius_old", "Quaternius (older", "L", "R", false, Axes::y_along_bone, 1.0f, "", {}};
    s.joints = {{"Root", "", "root"},           {"Foot.<", "Root", "foot<"},        {"Hips", "Root", "pelvis"},
                {"Abdomen", "Hips", "spine:1/2"}, {"Torso", "Abdomen", "spine:2/2"}, {"Neck", "Torso", "neck:1/1"},
                {"Head", "Neck", "head"},       {"Shoulder.<", "Torso", "clavicle<"}, {"UpperArm.<", "Shoulder.<", "upperarm<"},
                {"LowerArm.<", "UpperArm.<", "forearm<"}, {"Fist.<", "LowerArm.<", "hand<"},
                {"UpperLeg.<", "Hips", "thigh<"}, {"LowerLeg.<", "UpperLeg.<", "shin<"}, {"PoleTarget.<", "Root", "pole<"}};
    v.push_back(s);
  }
  auto humanik = [&](Spec s, bool end_bones, bool rolls, bool inhand, int spines, int necks) {
    const std::string top = spines == 1 ? "Spine" : "Spine" + std::to_string(spines - 1);
    s.joints = {{"Hips", s.joints.empty() ? "" : "Reference", "pelvis"}};
    if (rolls) s.joints.insert(s.joints.begin(), {"Reference", "", "root"});
    for (int i = 0; i < spines; ++i)
      s.joints.push_back({i ? "Spine" + std::to_string(i) : "Spine", i ? (i == 1 ? "Spine" : "Spine" + std::to_string(i - 1)) : "Hips",
                          "spine:" + std::to_string(i + 1) + "/" + std::to_string(spines)});
    for (int i = 0; i < necks; ++i)
      s.joints.push_back({i ? "Neck" + std::to_string(i) : "Neck", i ? (i == 1 ? "Neck" : "Neck" + std::to_string(i - 1)) : top,
                          "neck:" + std::to_string(i + 1) + "/" + std::to_string(necks)});
    const std::string neck_top = necks == 1 ? "Neck" : "Neck" + std::to_string(necks - 1);
    s.joints.push_back({"Head", neck_top, "head"});
    if (end_bones) s.joints.push_back({"HeadTop_End", "Head", "headtop"});
    for (const Joint& j : std::vector<Joint>{{"<Shoulder", top, "clavicle<"}, {"<Arm", "<Shoulder", "upperarm<"},
                                             {"<ForeArm", "<Arm", "forearm<"}, {"<Hand", "<ForeArm", "hand<"}})
      s.joints.push_back(j);
    if (rolls) {
      s.joints.push_back({"<ArmRoll", "<Arm", "mid:upperarm:forearm<"});
      s.joints.push_back({"<ForeArmRoll", "<ForeArm", "mid:forearm:hand<"});
    }
    for (const std::string& f : fingers) {
      std::string F = f;
      F[0] = static_cast<char>(std::toupper(F[0]));
      std::string parent = "<Hand";
      if (inhand && f != "thumb") {
        s.joints.push_back({"<InHand" + F, "<Hand", "finger:" + f + ":0<"});
        parent = "<InHand" + F;
      }
      for (int k = 1; k <= (end_bones ? 4 : 3); ++k) {
        s.joints.push_back({"<Hand" + F + std::to_string(k), parent, "finger:" + f + ":" + std::to_string(k) + "<"});
        parent = "<Hand" + F + std::to_string(k);
      }
    }
    for (const Joint& j : std::vector<Joint>{{"<UpLeg", "Hips", "thigh<"}, {"<Leg", "<UpLeg", "shin<"},
                                             {"<Foot", "<Leg", "foot<"}, {"<ToeBase", "<Foot", "toe<"}})
      s.joints.push_back(j);
    if (end_bones) s.joints.push_back({"<Toe_End", "<ToeBase", "toeend<"});
    if (rolls) {
      s.joints.push_back({"<UpLegRoll", "<UpLeg", "mid:thigh:shin<"});
      s.joints.push_back({"<LegRoll", "<Leg", "mid:shin:foot<"});
    }
    return s;
  };
  v.push_back(humanik(Spec{"mixamo", "Mixamo", "Left", "Right", false, Axes::identity, 100.0f, "mixamorig:", {}}, true,
                      false, false, 3, 1));
  v.push_back(humanik(Spec{"mixamo_plain", "Mixamo", "Left", "Right", false, Axes::identity, 1.0f, "", {}}, true, false,
                      false, 3, 1));
  {
    Spec s{"humanik", "Maya HumanIK", "Left", "Right", false, Axes::x_along_bone, 100.0f, "", {}};
    s.joints = {{"Reference", "", "root"}};
    v.push_back(humanik(s, false, true, false, 4, 2));
  }
  v.push_back(humanik(Spec{"axis_neuron", "Axis Neuron BVH", "Left", "Right", false, Axes::identity, 100.0f, "", {}},
                      false, false, true, 4, 1));
  {  // CMU (cgspeed BVH): LHipJoint, LowerBack, Spine, Spine1, Neck, Neck1, LThumb.
    Spec s{"cmu", "CMU / MotionBuilder BVH", "Left", "Right", false, Axes::identity, 1.0f / 0.056444f, "", {}};
    s.joints = {{"Hips", "", "pelvis"},           {"LHipJoint", "Hips", "pelvis"},  {"LeftUpLeg", "LHipJoint", "thigh.L"},
                {"LeftLeg", "LeftUpLeg", "shin.L"}, {"LeftFoot", "LeftLeg", "foot.L"}, {"LeftToeBase", "LeftFoot", "toe.L"},
                {"RHipJoint", "Hips", "pelvis"},  {"RightUpLeg", "RHipJoint", "thigh.R"}, {"RightLeg", "RightUpLeg", "shin.R"},
                {"RightFoot", "RightLeg", "foot.R"}, {"RightToeBase", "RightFoot", "toe.R"},
                {"LowerBack", "Hips", "spine:1/3"}, {"Spine", "LowerBack", "spine:2/3"}, {"Spine1", "Spine", "spine:3/3"},
                {"Neck", "Spine1", "neck:1/2"},   {"Neck1", "Neck", "neck:2/2"},      {"Head", "Neck1", "head"},
                {"<Shoulder", "Spine1", "clavicle<"}, {"<Arm", "<Shoulder", "upperarm<"}, {"<ForeArm", "<Arm", "forearm<"},
                {"<Hand", "<ForeArm", "hand<"},   {"<FingerBase", "<Hand", "finger:index:0<"},
                {"<HandIndex1", "<FingerBase", "finger:index:1<"}};
    s.joints.push_back({"LThumb", "LeftHand", "finger:thumb:1.L"});
    s.joints.push_back({"RThumb", "RightHand", "finger:thumb:1.R"});
    v.push_back(s);
  }
  for (int ue = 4; ue <= 5; ++ue) {  // Unreal mannequins, A-pose, centimetres, X along the bones.
    Spec s{ue == 4 ? "ue4" : "ue5", ue == 4 ? "Unreal mannequin (UE4)" : "Unreal mannequin (UE5)", "l", "r", true,
           Axes::x_along_bone, 100.0f, "", {}};
    const int n = ue == 4 ? 3 : 5, necks = ue == 4 ? 1 : 2;
    s.joints = {{"root", "", "root"}, {"pelvis", "root", "pelvis"}};
    for (int i = 1; i <= n; ++i)
      s.joints.push_back({"spine_0" + std::to_string(i), i == 1 ? "pelvis" : "spine_0" + std::to_string(i - 1),
                          "spine:" + std::to_string(i) + "/" + std::to_string(n)});
    const std::string top = "spine_0" + std::to_string(n);
    for (int i = 1; i <= necks; ++i)
      s.joints.push_back({"neck_0" + std::to_string(i), i == 1 ? top : "neck_01", "neck:" + std::to_string(i) + "/" + std::to_string(necks)});
    s.joints.push_back({"head", "neck_0" + std::to_string(necks), "head"});
    for (const Joint& j : std::vector<Joint>{{"clavicle_<", top, "clavicle<"}, {"upperarm_<", "clavicle_<", "upperarm<"},
                                             {"lowerarm_<", "upperarm_<", "forearm<"}, {"hand_<", "lowerarm_<", "hand<"},
                                             {"upperarm_twist_01_<", "upperarm_<", "mid:upperarm:forearm<"},
                                             {"lowerarm_twist_01_<", "lowerarm_<", "mid:forearm:hand<"}})
      s.joints.push_back(j);
    for (const std::string& f : fingers) {
      std::string parent = "hand_<";
      if (ue == 5 && f != "thumb") {
        s.joints.push_back({f + "_metacarpal_<", "hand_<", "finger:" + f + ":0<"});
        parent = f + "_metacarpal_<";
      }
      for (int k = 1; k <= 3; ++k) {
        s.joints.push_back({f + "_0" + std::to_string(k) + "_<", parent, "finger:" + f + ":" + std::to_string(k) + "<"});
        parent = f + "_0" + std::to_string(k) + "_<";
      }
    }
    for (const Joint& j : std::vector<Joint>{{"thigh_<", "pelvis", "thigh<"}, {"calf_<", "thigh_<", "shin<"},
                                             {"foot_<", "calf_<", "foot<"}, {"ball_<", "foot_<", "toe<"},
                                             {"thigh_twist_01_<", "thigh_<", "mid:thigh:shin<"},
                                             {"calf_twist_01_<", "calf_<", "mid:shin:foot<"},
                                             {"ik_foot_root", "root", "root"}, {"ik_foot_<", "ik_foot_root", "foot<"},
                                             {"ik_hand_root", "root", "root"}, {"ik_hand_gun", "ik_hand_root", "hand.R"},
                                             {"ik_hand_<", "ik_hand_gun", "hand<"}})
      s.joints.push_back(j);
    v.push_back(s);
  }
  {  // Blender Rigify, generated rig: DEF- deform chain (with .001 twist segments), some ORG-/MCH- bones.
    Spec s{"rigify", "Blender Rigify (DEF-)", "L", "R", true, Axes::y_along_bone, 1.0f, "", {}};
    s.joints = {{"DEF-spine", "", "pelvis"}};
    for (int i = 1; i <= 6; ++i) {
      const std::string name = "DEF-spine.00" + std::to_string(i), parent = i == 1 ? "DEF-spine" : "DEF-spine.00" + std::to_string(i - 1);
      s.joints.push_back({name, parent, i <= 3 ? "spine:" + std::to_string(i) + "/3" : i <= 5 ? "neck:" + std::to_string(i - 3) + "/2" : "head"});
    }
    for (const Joint& j : std::vector<Joint>{{"DEF-shoulder.<", "DEF-spine.003", "clavicle<"},
                                             {"DEF-upper_arm.<", "DEF-shoulder.<", "upperarm<"},
                                             {"DEF-upper_arm.<.001", "DEF-upper_arm.<", "mid:upperarm:forearm<"},
                                             {"DEF-forearm.<", "DEF-upper_arm.<.001", "forearm<"},
                                             {"DEF-forearm.<.001", "DEF-forearm.<", "mid:forearm:hand<"},
                                             {"DEF-hand.<", "DEF-forearm.<.001", "hand<"}})
      s.joints.push_back(j);
    for (const std::string& f : fingers) {
      std::string parent = "DEF-hand.<";
      for (int k = 1; k <= 3; ++k) {
        const std::string name = (f == "thumb" ? "DEF-thumb.0" : "DEF-f_" + f + ".0") + std::to_string(k) + ".<";
        s.joints.push_back({name, parent, "finger:" + f + ":" + std::to_string(k) + "<"});
        parent = name;
      }
    }
    for (const Joint& j : std::vector<Joint>{{"DEF-thigh.<", "DEF-spine", "thigh<"},
                                             {"DEF-thigh.<.001", "DEF-thigh.<", "mid:thigh:shin<"},
                                             {"DEF-shin.<", "DEF-thigh.<.001", "shin<"},
                                             {"DEF-shin.<.001", "DEF-shin.<", "mid:shin:foot<"},
                                             {"DEF-foot.<", "DEF-shin.<.001", "foot<"}, {"DEF-toe.<", "DEF-foot.<", "toe<"},
                                             {"ORG-thigh.<", "DEF-spine", "thigh<"}, {"MCH-foot_ik.<", "DEF-spine", "foot<"},
                                             {"DEF-breast.<", "DEF-spine.003", "chestside<"}})
      s.joints.push_back(j);
    v.push_back(s);
  }
  {  // The Blender human metarig.
    Spec s{"metarig", "Blender metarig", "L", "R", true, Axes::y_along_bone, 1.0f, "", {}};
    s.joints = {{"spine", "", "pelvis"}};
    for (int i = 1; i <= 6; ++i)
      s.joints.push_back({"spine.00" + std::to_string(i), i == 1 ? "spine" : "spine.00" + std::to_string(i - 1),
                          i <= 3 ? "spine:" + std::to_string(i) + "/3" : i <= 5 ? "neck:" + std::to_string(i - 3) + "/2" : "head"});
    for (const Joint& j : std::vector<Joint>{{"shoulder.<", "spine.003", "clavicle<"}, {"upper_arm.<", "shoulder.<", "upperarm<"},
                                             {"forearm.<", "upper_arm.<", "forearm<"}, {"hand.<", "forearm.<", "hand<"},
                                             {"palm.01.<", "hand.<", "finger:index:0<"},
                                             {"f_index.01.<", "palm.01.<", "finger:index:1<"},
                                             {"f_index.02.<", "f_index.01.<", "finger:index:2<"},
                                             {"thumb.01.<", "hand.<", "finger:thumb:1<"},
                                             {"thigh.<", "spine", "thigh<"}, {"shin.<", "thigh.<", "shin<"},
                                             {"foot.<", "shin.<", "foot<"}, {"toe.<", "foot.<", "toe<"},
                                             {"heel.02.<", "foot.<", "heel<"}, {"breast.<", "spine.003", "chestside<"},
                                             {"pelvis.<", "spine", "hipside<"}})
      s.joints.push_back(j);
    v.push_back(s);
  }
  {  // 3ds Max Biped: thighs off Bip01 Spine, clavicles off Bip01 Neck, Nub end bones, Footsteps.
    Spec s{"biped", "3ds Max Biped", "L", "R", false, Axes::x_along_bone, 39.37f, "", {}};
    s.joints = {{"Bip01", "", "root"},
                {"Bip01 Footsteps", "Bip01", "root"},
                {"Bip01 Pelvis", "Bip01", "pelvis"},
                {"Bip01 Spine", "Bip01 Pelvis", "spine:1/3"},
                {"Bip01 Spine1", "Bip01 Spine", "spine:2/3"},
                {"Bip01 Spine2", "Bip01 Spine1", "spine:3/3"},
                {"Bip01 Neck", "Bip01 Spine2", "neck:1/1"},
                {"Bip01 Head", "Bip01 Neck", "head"},
                {"Bip01 HeadNub", "Bip01 Head", "headtop"},
                {"Bip01 < Clavicle", "Bip01 Neck", "clavicle<"},
                {"Bip01 < UpperArm", "Bip01 < Clavicle", "upperarm<"},
                {"Bip01 < Forearm", "Bip01 < UpperArm", "forearm<"},
                {"Bip01 < Hand", "Bip01 < Forearm", "hand<"}};
    for (int f = 0; f < 5; ++f) {
      std::string parent = "Bip01 < Hand";
      for (int k = 0; k < 3; ++k) {
        const std::string name = "Bip01 < Finger" + std::to_string(f) + (k ? std::to_string(k) : "");
        s.joints.push_back({name, parent, "finger:" + fingers[static_cast<std::size_t>(f)] + ":" + std::to_string(k + 1) + "<"});
        parent = name;
      }
      s.joints.push_back({"Bip01 < Finger" + std::to_string(f) + "Nub", parent,
                          "finger:" + fingers[static_cast<std::size_t>(f)] + ":4<"});
    }
    for (const Joint& j : std::vector<Joint>{{"Bip01 < Thigh", "Bip01 Spine", "thigh<"}, {"Bip01 < Calf", "Bip01 < Thigh", "shin<"},
                                             {"Bip01 < Foot", "Bip01 < Calf", "foot<"}, {"Bip01 < Toe0", "Bip01 < Foot", "toe<"},
                                             {"Bip01 < Toe0Nub", "Bip01 < Toe0", "toeend<"}})
      s.joints.push_back(j);
    v.push_back(s);
  }
  {  // Daz Genesis 8: hip -> pelvis -> thighs; bend/twist pairs; A-pose.
    Spec s{"daz", "Daz Genesis", "l", "r", true, Axes::x_along_bone, 100.0f, "", {}};
    s.joints = {{"hip", "", "pelvis"},          {"pelvis", "hip", "pelvis"},
                {"<ThighBend", "pelvis", "thigh<"}, {"<ThighTwist", "<ThighBend", "mid:thigh:shin<"},
                {"<Shin", "<ThighTwist", "shin<"}, {"<Foot", "<Shin", "foot<"},
                {"<Metatarsals", "<Foot", "mid:foot:toe<"}, {"<Toe", "<Metatarsals", "toe<"},
                {"abdomenLower", "hip", "spine:1/4"}, {"abdomenUpper", "abdomenLower", "spine:2/4"},
                {"chestLower", "abdomenUpper", "spine:3/4"}, {"chestUpper", "chestLower", "spine:4/4"},
                {"neckLower", "chestUpper", "neck:1/2"}, {"neckUpper", "neckLower", "neck:2/2"},
                {"head", "neckUpper", "head"},      {"<Pectoral", "chestUpper", "chestside<"},
                {"<Collar", "chestUpper", "clavicle<"}, {"<ShldrBend", "<Collar", "upperarm<"},
                {"<ShldrTwist", "<ShldrBend", "mid:upperarm:forearm<"}, {"<ForearmBend", "<ShldrTwist", "forearm<"},
                {"<ForearmTwist", "<ForearmBend", "mid:forearm:hand<"}, {"<Hand", "<ForearmTwist", "hand<"},
                {"<Thumb1", "<Hand", "finger:thumb:1<"}, {"<Thumb2", "<Thumb1", "finger:thumb:2<"},
                {"<Carpal1", "<Hand", "finger:index:0<"}, {"<Index1", "<Carpal1", "finger:index:1<"},
                {"<Index2", "<Index1", "finger:index:2<"}, {"<Carpal2", "<Hand", "finger:middle:0<"},
                {"<Mid1", "<Carpal2", "finger:middle:1<"}};
    v.push_back(s);
  }
  {  // Daz / Poser BVH names.
    Spec s{"daz_bvh", "Daz / Poser", "l", "r", false, Axes::identity, 100.0f, "", {}};
    s.joints = {{"hip", "", "pelvis"},         {"abdomen", "hip", "spine:1/2"}, {"chest", "abdomen", "spine:2/2"},
                {"neck", "chest", "neck:1/1"}, {"head", "neck", "head"},        {"<Collar", "chest", "clavicle<"},
                {"<Shldr", "<Collar", "upperarm<"}, {"<ForeArm", "<Shldr", "forearm<"}, {"<Hand", "<ForeArm", "hand<"},
                {"<Buttock", "hip", "hipside<"}, {"<Thigh", "<Buttock", "thigh<"}, {"<Shin", "<Thigh", "shin<"},
                {"<Foot", "<Shin", "foot<"}};
    v.push_back(s);
  }
  {  // KayKit: lower-case names, wrist + hand + handslot, IK and control helpers on the root.
    Spec s{"kaykit", "KayKit", "l", "r", false, Axes::y_along_bone, 1.0f, "", {}};
    s.joints = {{"root", "", "root"},          {"hips", "root", "pelvis"},          {"spine", "hips", "spine:1/2"},
                {"chest", "spine", "spine:2/2"}, {"head", "chest", "head"},         {"upperarm.<", "chest", "upperarm<"},
                {"lowerarm.<", "upperarm.<", "forearm<"}, {"wrist.<", "lowerarm.<", "hand<"},
                {"hand.<", "wrist.<", "finger:middle:0<"}, {"handslot.<", "hand.<", "finger:middle:2<"},
                {"upperleg.<", "hips", "thigh<"}, {"lowerleg.<", "upperleg.<", "shin<"}, {"foot.<", "lowerleg.<", "foot<"},
                {"toes.<", "foot.<", "toe<"},   {"kneeIK.<", "root", "pole<"},       {"control-foot-roll.<", "root", "heel<"},
                {"heelIK.<", "control-foot-roll.<", "heel<"}, {"control-toe-roll.<", "heelIK.<", "toe<"},
                {"handIK.<", "root", "hand<"},  {"elbowIK.<", "root", "forearm<"}};
    v.push_back(s);
  }
  {  // VRM humanoid bone names (1.0: thumb metacarpal/proximal/distal).
    Spec s{"vrm", "VRM humanoid", "left", "right", false, Axes::identity, 1.0f, "", {}};
    s.joints = {{"hips", "", "pelvis"},           {"spine", "hips", "spine:1/3"},      {"chest", "spine", "spine:2/3"},
                {"upperChest", "chest", "spine:3/3"}, {"neck", "upperChest", "neck:1/1"}, {"head", "neck", "head"},
                {"<Shoulder", "upperChest", "clavicle<"}, {"<UpperArm", "<Shoulder", "upperarm<"},
                {"<LowerArm", "<UpperArm", "forearm<"}, {"<Hand", "<LowerArm", "hand<"},
                {"<ThumbMetacarpal", "<Hand", "finger:thumb:1<"}, {"<ThumbProximal", "<ThumbMetacarpal", "finger:thumb:2<"},
                {"<ThumbDistal", "<ThumbProximal", "finger:thumb:3<"}, {"<IndexProximal", "<Hand", "finger:index:1<"},
                {"<IndexIntermediate", "<IndexProximal", "finger:index:2<"},
                {"<IndexDistal", "<IndexIntermediate", "finger:index:3<"},
                {"<UpperLeg", "hips", "thigh<"}, {"<LowerLeg", "<UpperLeg", "shin<"}, {"<Foot", "<LowerLeg", "foot<"},
                {"<Toes", "<Foot", "toe<"}};
    v.push_back(s);
  }
  {  // OptiTrack Motive skeleton, names prefixed with the skeleton's name.
    Spec s{"optitrack", "OptiTrack / Arena", "L", "R", false, Axes::identity, 1.0f, "Skeleton1_", {}};
    s.joints = {{"Hip", "", "pelvis"},      {"Ab", "Hip", "spine:1/2"},       {"Chest", "Ab", "spine:2/2"},
                {"Neck", "Chest", "neck:1/1"}, {"Head", "Neck", "head"},      {"<Shoulder", "Chest", "clavicle<"},
                {"<UArm", "<Shoulder", "upperarm<"}, {"<FArm", "<UArm", "forearm<"}, {"<Hand", "<FArm", "hand<"},
                {"<Thigh", "Hip", "thigh<"}, {"<Shin", "<Thigh", "shin<"},   {"<Foot", "<Shin", "foot<"},
                {"<Toe", "<Foot", "toe<"}};
    v.push_back(s);
  }
  {  // No convention: Blender's default bone names; the structure has to tell.
    Spec s{"unnamed", "structural", "", "", false, Axes::y_along_bone, 1.0f, "", {}};
    int n = 0;
    auto nm = [&] { return n++ ? "Bone." + std::string(n - 1 < 10 ? "00" : "0") + std::to_string(n - 1) : std::string("Bone"); };
    const std::string pelvis = nm(), s1 = nm(), s2 = nm(), neck = nm(), head = nm();
    s.joints = {{pelvis, "", "pelvis"}, {s1, pelvis, "spine:1/2"}, {s2, s1, "spine:2/2"}, {neck, s2, "neck:1/1"}, {head, neck, "head"}};
    for (const char* side : {".L", ".R"}) {
      const std::string sd = side;
      const std::string c = nm(), u = nm(), f = nm(), h = nm(), t = nm(), sh = nm(), ft = nm(), toe = nm();
      s.joints.push_back({c, s2, "clavicle" + sd});
      s.joints.push_back({u, c, "upperarm" + sd});
      s.joints.push_back({f, u, "forearm" + sd});
      s.joints.push_back({h, f, "hand" + sd});
      s.joints.push_back({t, pelvis, "thigh" + sd});
      s.joints.push_back({sh, t, "shin" + sd});
      s.joints.push_back({ft, sh, "foot" + sd});
      s.joints.push_back({toe, ft, "toe" + sd});
    }
    v.push_back(s);
  }
  return v;
}

// A four-legged animal (Quaternius-animal-like names): not a humanoid.
inline Spec quadruped() {
  Spec s{"quadruped", "", "L", "R", false, Axes::y_along_bone, 1.0f, "", {}, false};
  s.joints = {{"Body", "", "at:0,0.6,0"},           {"Spine", "Body", "at:0,0.62,0.3"},
              {"Neck", "Spine", "at:0,0.75,0.5"},     {"Head", "Neck", "at:0,0.85,0.65"},
              {"Tail1", "Body", "at:0,0.6,-0.3"},     {"Tail2", "Tail1", "at:0,0.55,-0.5"},
              {"FrontUpperLeg.<", "Spine", "at:0.12,0.5,0.35<"}, {"FrontLowerLeg.<", "FrontUpperLeg.<", "at:0.12,0.25,0.35<"},
              {"FrontFoot.<", "FrontLowerLeg.<", "at:0.12,0.02,0.38<"},
              {"BackUpperLeg.<", "Body", "at:0.12,0.5,-0.15<"}, {"BackLowerLeg.<", "BackUpperLeg.<", "at:0.12,0.25,-0.2<"},
              {"BackFoot.<", "BackLowerLeg.<", "at:0.12,0.02,-0.18<"}, {"IKBackLeg.<", "Body", "at:0.12,0.02,-0.18<"},
              {"PoleTarget.<", "Body", "at:0.12,0.3,0.2<"}};
  return s;
}

}  // namespace rigfix
