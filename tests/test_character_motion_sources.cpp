// Motions from every source a user has, written from code: BVH files in
// joint-named (Biovision), CMU ASF-named, CMU 3ds Max-named and opaquely
// named rigs, Y-up and Z-up, metres and centimetres, with sloppy headers;
// ASF/AMC pairs; a glTF character's clip. Each drives every character
// convention of tests/rig_fixtures.hpp like the same motion in CMU names.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "character_fixtures.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/io/asf.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/error.hpp"
#include "rig_fixtures.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;
using Catch::Matchers::StartsWith;

namespace {

namespace fs = std::filesystem;

std::string temp_dir() {
  const fs::path d = fs::temp_directory_path() / "gatcore_motion_sources";
  fs::create_directories(d);
  return d.string();
}

std::string write(const std::string& name, const std::string& text) {
  const std::string p = temp_dir() + "/" + name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

rigfix::Spec spec_named(const std::string& id) {
  for (const rigfix::Spec& s : rigfix::specs())
    if (s.id == id) return s;
  FAIL("no fixture rig " << id);
  return {};
}

// Biovision / OptiTrack BVH: names say the joint a bone starts at.
rigfix::Spec joint_named() {
  rigfix::Spec s{"joint_named", "Joint-named", "Left", "Right", false, rigfix::Axes::identity, 1.0f, "", {}};
  s.joints = {{"Hips", "", "pelvis"},          {"Chest", "Hips", "spine:1/2"},        {"Chest2", "Chest", "spine:2/2"},
              {"Neck", "Chest2", "neck:1/1"},  {"Head", "Neck", "head"},              {"<Collar", "Chest2", "clavicle<"},
              {"<Shoulder", "<Collar", "upperarm<"}, {"<Elbow", "<Shoulder", "forearm<"}, {"<Wrist", "<Elbow", "hand<"},
              {"<Hip", "Hips", "thigh<"},      {"<Knee", "<Hip", "shin<"},            {"<Ankle", "<Knee", "foot<"},
              {"<Toe", "<Ankle", "toe<"}};
  return s;
}

// The CMU database's ASF bone names, a joint per bone at its start: the hip
// joints and the lower back start at the root, the clavicles where the neck
// starts, the hand and the thumb at the end of the wrist.
rigfix::Spec asf_named() {
  rigfix::Spec s{"asf_named", "CMU ASF", "l", "r", false, rigfix::Axes::identity, 1.0f, "", {}};
  s.joints = {{"root", "", "pelvis"},
              {"<hipjoint", "root", "pelvis"},
              {"<femur", "<hipjoint", "thigh<"},
              {"<tibia", "<femur", "shin<"},
              {"<foot", "<tibia", "foot<"},
              {"<toes", "<foot", "toe<"},
              {"lowerback", "root", "pelvis"},
              {"upperback", "lowerback", "spine:1/3"},
              {"thorax", "upperback", "spine:2/3"},
              {"lowerneck", "thorax", "spine:3/3"},
              {"upperneck", "lowerneck", "neck:1/1"},
              {"head", "upperneck", "head"},
              {"<clavicle", "thorax", "at:0,1.42,0<"},
              {"<humerus", "<clavicle", "upperarm<"},
              {"<radius", "<humerus", "forearm<"},
              {"<wrist", "<radius", "hand<"},
              {"<hand", "<wrist", "at:0.75,1.45,0<"},
              {"<fingers", "<hand", "at:0.8,1.45,0<"},
              {"<thumb", "<wrist", "at:0.75,1.45,0<"}};
  return s;
}

// The CMU captures' 3ds Max conversion: LHipJoint, LeftHip (the thigh),
// LeftKnee, LeftAnkle, LeftToe, lowerback, Chest, LeftCollar, LeftShoulder
// (the upper arm), LeftElbow, LeftWrist.
rigfix::Spec max_named() {
  rigfix::Spec s{"max_named", "Joint-named", "Left", "Right", false, rigfix::Axes::identity, 1.0f, "", {}};
  s.joints = {{"Hips", "", "pelvis"},
              {"LHipJoint", "Hips", "pelvis"},
              {"LeftHip", "LHipJoint", "thigh.L"},
              {"LeftKnee", "LeftHip", "shin.L"},
              {"LeftAnkle", "LeftKnee", "foot.L"},
              {"LeftToe", "LeftAnkle", "toe.L"},
              {"RHipJoint", "Hips", "pelvis"},
              {"RightHip", "RHipJoint", "thigh.R"},
              {"RightKnee", "RightHip", "shin.R"},
              {"RightAnkle", "RightKnee", "foot.R"},
              {"RightToe", "RightAnkle", "toe.R"},
              {"lowerback", "Hips", "spine:1/3"},
              {"Chest", "lowerback", "spine:2/3"},
              {"Chest2", "Chest", "spine:3/3"},
              {"Neck", "Chest2", "neck:1/1"},
              {"Head", "Neck", "head"},
              {"<Collar", "Chest2", "clavicle<"},
              {"<Shoulder", "<Collar", "upperarm<"},
              {"<Elbow", "<Shoulder", "forearm<"},
              {"<Wrist", "<Elbow", "hand<"}};
  return s;
}

// The ASF hierarchy under names no table knows: only the structure tells.
rigfix::Spec opaque() {
  rigfix::Spec s = asf_named();
  s.id = "opaque";
  s.convention = "structural";
  std::map<std::string, std::string> rename;
  int n = 0;
  for (rigfix::Joint& j : s.joints) {
    const std::string base = j.name;
    if (!rename.count(base)) rename[base] = (base.find('<') != std::string::npos ? "<q" : "q") + std::to_string(37 + 7 * n++);
  }
  for (rigfix::Joint& j : s.joints) {
    j.name = rename[j.name];
    if (!j.parent.empty()) j.parent = rename[j.parent];
  }
  s.left = "x_";
  s.right = "k_";
  return s;
}

// MotionBuilder's Biovision export and similar: LeftUpArm, LeftLowArm, LeftUpLeg, LeftLowLeg.
rigfix::Spec generic_named() {
  rigfix::Spec s{"generic", "Generic bone names", "Left", "Right", false, rigfix::Axes::identity, 1.0f, "", {}};
  s.joints = {{"Hips", "", "pelvis"},          {"Chest", "Hips", "spine:1/2"},        {"Chest1", "Chest", "spine:2/2"},
              {"Neck", "Chest1", "neck:1/1"},  {"Head", "Neck", "head"},              {"<Collar", "Chest1", "clavicle<"},
              {"<UpArm", "<Collar", "upperarm<"}, {"<LowArm", "<UpArm", "forearm<"},  {"<Hand", "<LowArm", "hand<"},
              {"<UpLeg", "Hips", "thigh<"},    {"<LowLeg", "<UpLeg", "shin<"},        {"<Foot", "<LowLeg", "foot<"},
              {"<ToeBase", "<Foot", "toe<"}};
  return s;
}

// Bone-named arms (LeftShoulder the collar, LeftArm the upper arm) on joint-named legs
// (LeftHip the thigh): the names are shifted by one bone between the limbs.
rigfix::Spec mixed_named() {
  rigfix::Spec s{"mixed", "Joint-named", "Left", "Right", false, rigfix::Axes::identity, 1.0f, "", {}};
  s.joints = {{"Hips", "", "pelvis"},          {"Chest", "Hips", "spine:1/2"},        {"Chest2", "Chest", "spine:2/2"},
              {"Neck", "Chest2", "neck:1/1"},  {"Head", "Neck", "head"},              {"<Shoulder", "Chest2", "clavicle<"},
              {"<Arm", "<Shoulder", "upperarm<"}, {"<ForeArm", "<Arm", "forearm<"},  {"<Hand", "<ForeArm", "hand<"},
              {"<Hip", "Hips", "thigh<"},      {"<Knee", "<Hip", "shin<"},            {"<Ankle", "<Knee", "foot<"},
              {"<Toe", "<Ankle", "toe<"}};
  return s;
}

// Left knee bent 45 degrees, left arm raised 60 degrees, right thigh 30
// forward, right elbow 60; the body moved.
std::vector<rigfix::PartPose> pose() {
  rigfix::PartPose p;
  p.zxy = {{"shin.L", {0, 45, 0}}, {"upperarm.L", {60, 0, 0}}, {"thigh.R", {0, -30, 0}}, {"forearm.R", {0, 0, 60}}};
  p.move = {0.1f, 0.0f, 0.3f};
  return {p};
}

// The whole motion turned by r (skeleton and clip, rest rotations kept zero).
Motion turned(Motion m, const Quat& r) {
  auto turn_root = [&](Transform& t) {
    t.translation = quat_rotate(r, t.translation);
    t.rotation = quat_normalize(quat_mul(r, t.rotation));
  };
  Skeleton& s = m.skeleton;
  // Every offset turns; roots' rotations turn from the left, others conjugate.
  auto turn = [&](std::vector<Transform>& local) {
    for (std::int32_t j = 0; j < s.num_joints(); ++j) {
      if (s.parents[j] < 0) {
        turn_root(local[j]);
      } else {
        local[j].translation = quat_rotate(r, local[j].translation);
        local[j].rotation = quat_normalize(quat_mul(quat_mul(r, local[j].rotation), Quat{-r[0], -r[1], -r[2], r[3]}));
      }
    }
  };
  for (Pose& p : m.clip.frames) turn(p.local);
  turn(s.rest_local);
  // Roots: their rest rotation is r now; fold it so rest rotations stay zero
  // as BVH has them (the children's rest offsets were turned above).
  for (std::int32_t j = 0; j < s.num_joints(); ++j)
    if (s.parents[j] < 0) {
      const Quat inv{-r[0], -r[1], -r[2], r[3]};
      s.rest_local[j].rotation = {0, 0, 0, 1};
      for (Pose& p : m.clip.frames) p.local[j].rotation = quat_normalize(quat_mul(p.local[j].rotation, inv));
    }
  std::vector<Mat4> g(static_cast<std::size_t>(s.num_joints()));
  for (std::int32_t j = 0; j < s.num_joints(); ++j) {
    g[j] = s.parents[j] < 0 ? to_matrix(s.rest_local[j]) : mul(g[s.parents[j]], to_matrix(s.rest_local[j]));
    s.inverse_bind[j] = inverse(g[j]);
  }
  return m;
}

// The motion stood Z up (Y-up x, y, z -> x, -z, y), as Vicon and 3ds Max write.
Motion z_up(const Motion& m) { return turned(m, quat_from_axis_angle({1.0f, 0.0f, 0.0f}, 1.5707963f)); }

// R = Rz(c) Ry(b) Rx(a) (ASF "rx ry rz"), angles in degrees.
Vec3 xyz_degrees(const Quat& q) {
  const Mat4 m = to_matrix(Transform{{0, 0, 0}, q, {1, 1, 1}});
  auto R = [&](int r, int c) { return m[std::size_t(c * 4 + r)]; };
  const float b = -std::asin(std::clamp(R(2, 0), -1.0f, 1.0f));
  return {std::atan2(R(2, 1), R(2, 2)) * 57.2957795f, b * 57.2957795f, std::atan2(R(1, 0), R(0, 0)) * 57.2957795f};
}

// The ASF-named rig as an ASF/AMC pair: lengths scaled by :units length
// 0.45, angles in degrees, the femurs and humeri with tilted axes (so
// C M C^-1 matters), a radius with one dof only.
std::pair<std::string, std::string> asf_amc(const rigfix::Spec& spec, const std::vector<rigfix::PartPose>& poses,
                                            bool radians = false) {
  const rigfix::Expanded e = rigfix::expand(spec);
  const std::size_t J = e.names.size();
  std::vector<std::vector<std::size_t>> kids(J);
  for (std::size_t j = 0; j < J; ++j)
    if (e.parents[j] >= 0) kids[std::size_t(e.parents[j])].push_back(j);
  const std::vector<std::string> part = rigfix::joint_parts(spec);  // for the pose
  const double scale = 0.45;
  const double to_unit = radians ? 3.14159265358979 / 180.0 : 1.0;
  auto axis_of = [&](const std::string& n) -> Vec3 {
    if (n.find("femur") != std::string::npos) return {0, 0, n[0] == 'l' ? 20.0f : -20.0f};
    if (n.find("humerus") != std::string::npos) return {10, 5, n[0] == 'l' ? -30.0f : 30.0f};
    return {0, 0, 0};
  };
  std::ostringstream a;
  a << "# generated\r\n:version 1.10\n:name test\n:units\n  mass 1.0\n  length 0.45\n  angle " << (radians ? "rad" : "deg")
    << "\n:documentation\n  a test skeleton\n:root\n   order TX TY TZ RX RY RZ\n   axis XYZ\n   position "
    << e.pos[0][0] * scale << " " << e.pos[0][1] * scale << " " << e.pos[0][2] * scale
    << "\n   orientation 0 0 0\n:bonedata\n";
  for (std::size_t j = 1; j < J; ++j) {
    // The bone runs from its joint to its children's joint (all children start there).
    Vec3 d{0.0f, 0.0f, 0.05f};
    if (!kids[j].empty()) {
      const Vec3& c = e.pos[kids[j][0]];
      d = {c[0] - e.pos[j][0], c[1] - e.pos[j][1], c[2] - e.pos[j][2]};
    }
    const double len = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
    const Vec3 ax = axis_of(e.names[j]);
    a << "  begin\n\tid " << j << "\n\tname " << e.names[j] << "\n\tdirection " << (len > 0 ? d[0] / len : 0) << " "
      << (len > 0 ? d[1] / len : 0) << " " << (len > 0 ? d[2] / len : 1) << "\n\tlength " << len * scale << "\n\taxis "
      << ax[0] * to_unit << " " << ax[1] * to_unit << " " << ax[2] * to_unit << " XYZ\n";
    if (e.names[j].find("hipjoint") == std::string::npos) {
      const bool one = e.names[j].find("radius") != std::string::npos;
      a << "\tdof " << (one ? "rx" : "rx ry rz") << "\n\tlimits (-180.0 180.0)\n";
      if (!one) a << "\t       (-180.0 180.0)\n\t       (-inf inf)\n";
    }
    a << "  end\n";
  }
  a << ":hierarchy\n  begin\n";
  for (std::size_t j = 0; j < J; ++j)
    if (!kids[j].empty()) {
      a << "    " << e.names[j];
      for (std::size_t c : kids[j]) a << " " << e.names[c];
      a << "\n";
    }
  a << "  end\n";
  std::ostringstream m;
  m << "#!OML:ASF test.asf\n:FULLY-SPECIFIED\n" << (radians ? ":RADIANS" : ":DEGREES") << "\n";
  for (std::size_t f = 0; f <= poses.size(); ++f) {
    m << f + 1 << "\n";
    const Vec3 mv = f > 0 ? poses[f - 1].move : Vec3{0, 0, 0};
    m << "root " << (e.pos[0][0] + mv[0]) * scale << " " << (e.pos[0][1] + mv[1]) * scale << " "
      << (e.pos[0][2] + mv[2]) * scale << " 0 0 0\n";
    for (std::size_t j = 1; j < J; ++j) {
      if (e.names[j].find("hipjoint") != std::string::npos) continue;
      Vec3 zxy{0, 0, 0};
      if (f > 0)
        if (auto it = poses[f - 1].zxy.find(part[j]); it != poses[f - 1].zxy.end()) zxy = it->second;
      // The local rotation BVH's "Zrotation Xrotation Yrotation" gives, as C M C^-1.
      auto rq = [](int axis, float deg) {
        Vec3 v{0, 0, 0};
        v[std::size_t(axis)] = 1.0f;
        return quat_from_axis_angle(v, deg * 0.0174532925f);
      };
      const Quat l = quat_mul(quat_mul(rq(2, zxy[0]), rq(0, zxy[1])), rq(1, zxy[2]));
      const Vec3 ax = axis_of(e.names[j]);
      const Quat c = quat_mul(rq(2, ax[2]), quat_mul(rq(1, ax[1]), rq(0, ax[0])));
      const Quat mq = quat_mul(quat_mul(Quat{-c[0], -c[1], -c[2], c[3]}, l), c);
      const Vec3 ang = xyz_degrees(mq);
      if (e.names[j].find("radius") != std::string::npos) {
        // One dof (rx): only a pure x rotation survives (the pose bends the radius about z, so skip).
        m << e.names[j] << " " << ang[0] * to_unit << "\n";
        continue;
      }
      m << e.names[j] << " " << ang[0] * to_unit << " " << ang[1] * to_unit << " " << ang[2] * to_unit << "\n";
    }
  }
  return {a.str(), m.str()};
}

std::vector<rigfix::PartPose> pose_without_elbow() {
  auto p = pose();
  p[0].zxy.erase("forearm.R");
  return p;
}

// The same rig with identity axes as a glTF character carrying the motion as a clip.
std::string gltf_with_clip(const rigfix::Spec& spec, const Motion& m, const std::string& name) {
  Character ch = rigfix::character(spec);
  Clip c;
  c.name = "wave";
  c.fps = m.clip.fps;
  for (const Pose& p : m.clip.frames) {
    Pose q;
    for (const std::string& n : ch.skeleton.names) q.local.push_back(p.local[std::size_t(m.skeleton.find(n))]);
    c.frames.push_back(q);
  }
  Clip idle = c;
  idle.name = "idle";
  for (Pose& p : idle.frames) p = Pose{ch.skeleton.rest_local};
  ch.clips = {idle, c};
  const std::string path = temp_dir() + "/" + name;
  save_gltf_character(ch, path);
  return path;
}

struct Source {
  std::string id;
  Motion motion;
};

Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
float dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
float angle_deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(dot(a, b) / std::sqrt(dot(a, a) * dot(b, b)), -1.0f, 1.0f)) * 57.29578f;
}

// Every source convention, as files of every kind.
std::vector<Source> sources(const std::vector<rigfix::PartPose>& poses) {
  std::vector<Source> out;
  for (rigfix::Spec spec :
       {spec_named("cmu"), joint_named(), asf_named(), max_named(), opaque(), generic_named(), mixed_named()}) {
    const std::string id = spec.id;
    out.push_back({id + " BVH Y-up m", load_bvh(write(id + "_m.bvh", rigfix::bvh(spec, poses)))});
    out.push_back({id + " BVH Z-up m", z_up(out.back().motion)});
    out.push_back({id + " BVH facing -X", turned(out[out.size() - 2].motion, quat_from_axis_angle({0, 1, 0}, -1.5707963f))});
    spec.units = 100.0f;
    out.push_back({id + " BVH Y-up cm", load_bvh(write(id + "_cm.bvh", rigfix::bvh(spec, poses)))});
    out.push_back({id + " BVH Z-up cm", z_up(out.back().motion)});
  }
  {
    const auto [asf, amc] = asf_amc(asf_named(), poses);
    out.push_back({"ASF/AMC degrees", load_motion(write("cmu_skel.asf", asf) + ":" + write("cmu_walk.amc", amc))});
    const auto [asf_r, amc_r] = asf_amc(asf_named(), poses, true);
    write("rad_01.amc", amc_r);
    write("rad.asf", asf_r);
    out.push_back({"ASF/AMC radians (02_01.amc -> 02.asf)", load_motion(temp_dir() + "/rad_01.amc")});
  }
  {
    const Motion m = load_bvh(write("jn_clip.bvh", rigfix::bvh(joint_named(), poses)));
    out.push_back({"glTF clip #wave", load_motion(gltf_with_clip(joint_named(), m, "jn_clip.glb") + "#wave")});
  }
  return out;
}

}  // namespace

TEST_CASE("joint-named, ASF-named, 3ds Max-named and opaque rigs map by meaning", "[character][rig][motion]") {
  for (const rigfix::Spec& spec : {joint_named(), asf_named(), max_named(), opaque(), generic_named(), mixed_named()}) {
    const Motion m = load_bvh(write(spec.id + "_map.bvh", rigfix::bvh(spec, pose())));
    const MotionRig r = map_motion_rig(m.skeleton);
    INFO(spec.id << "\n" << describe_rig(m.skeleton, r.mapping));
    CHECK_THAT(r.mapping.convention, StartsWith(spec.convention));
    REQUIRE(r.mapping.humanoid());
    CHECK(r.frame == "Y up, facing +Z");
    // Each part on the joint at its landmark.
    const rigfix::Expanded e = rigfix::expand(spec);
    std::map<std::string, Vec3> at;
    for (std::size_t j = 0; j < e.names.size(); ++j) at[e.names[j]] = e.pos[j];
    const std::map<std::string, std::string> where = {{"thigh.l", "thigh"}, {"shin.l", "shin"}, {"foot.l", "foot"},
                                                      {"upperarm.l", "upperarm"}, {"forearm.l", "forearm"},
                                                      {"hand.l", "hand"}};
    for (const auto& [part, lm] : where) {
      INFO(part);
      const std::int32_t j = r.mapping.find(part);
      REQUIRE(j >= 0);
      const Vec3 want = rigfix::landmark(lm, false), got = at[m.skeleton.names[j]];
      for (int k = 0; k < 3; ++k) CHECK(got[k] == Approx(want[k]).margin(1e-4));
    }
  }
  // Joint-named: LeftShoulder is the upper arm, LeftCollar the clavicle, LeftHip the thigh.
  const Motion jn = load_bvh(write("jn_names.bvh", rigfix::bvh(joint_named(), pose())));
  const RigMapping m = map_motion_rig(jn.skeleton).mapping;
  CHECK(jn.skeleton.names[m.find("upperarm.l")] == "LeftShoulder");
  CHECK(jn.skeleton.names[m.find("clavicle.l")] == "LeftCollar");
  CHECK(jn.skeleton.names[m.find("thigh.r")] == "RightHip");
  // ASF names: lfemur the thigh, lhumerus the upper arm, the hip joints helpers.
  const Motion an = load_bvh(write("asf_names.bvh", rigfix::bvh(asf_named(), pose())));
  const RigMapping ma = map_motion_rig(an.skeleton).mapping;
  CHECK(an.skeleton.names[ma.find("thigh.l")] == "lfemur");
  CHECK(an.skeleton.names[ma.find("upperarm.r")] == "rhumerus");
  CHECK(an.skeleton.names[ma.find("clavicle.l")] == "lclavicle");
  CHECK(ma.role[an.skeleton.find("lhipjoint")] == JointRole::helper);
}

TEST_CASE("an --alias overrides the mapping of a motion", "[character][rig][motion]") {
  const Motion m = load_bvh(write("alias.bvh", rigfix::bvh(joint_named(), pose())));
  BoneAliases al;
  al.pairs = {{normalise_bone_name("Chest2"), "neck"}};
  const std::string before = describe_motion_rig(m), after = describe_motion_rig(m, al);
  CHECK_THAT(before, Contains("spine     Chest, Chest2"));
  CHECK_THAT(after, Contains("spine     Chest\n"));
  CHECK_THAT(after, Contains("neck      Chest2, Neck"));
  CHECK_THAT(before, Contains("read as    Y up, facing +Z"));
}

TEST_CASE("Z-up motions are stood up, and motions facing away turned round", "[character][rig][motion]") {
  for (const rigfix::Spec& spec : {spec_named("cmu"), joint_named(), opaque()}) {
    const Motion m = z_up(load_bvh(write(spec.id + "_z.bvh", rigfix::bvh(spec, pose()))));
    const MotionRig r = map_motion_rig(m.skeleton);
    INFO(spec.id << "\n" << describe_rig(m.skeleton, r.mapping));
    REQUIRE(r.mapping.humanoid());
    CHECK(r.frame == "Z up, facing -Y (turned to Y up, facing +Z)");
    const Motion back = turned(load_bvh(write(spec.id + "_y.bvh", rigfix::bvh(spec, pose()))),
                               quat_from_axis_angle({0, 1, 0}, 3.14159265f));
    CHECK(map_motion_rig(back.skeleton).frame == "Y up, facing -Z (turned to Y up, facing +Z)");
  }
}

TEST_CASE("every motion convention drives every character convention like CMU names do", "[character][rig][retarget][motion]") {
  const auto all = sources(pose_without_elbow());
  const Motion& ref = all[0].motion;  // CMU names, Y-up, metres
  int pairs = 0;
  for (const rigfix::Spec& dst : rigfix::specs()) {
    const Skeleton target = rigfix::skeleton(dst);
    const RigMapping mt = map_rig(target);
    const Clip want = retarget(ref, target, mat4_identity());
    const auto wg = global_transforms(target, want.frames.back());
    const auto tg0 = global_transforms(target, bind_pose(target));
    float ground = 1e30f;
    for (const Mat4& g : tg0) ground = std::min(ground, g[13]);
    for (const Source& src : all) {
      INFO(src.id << " -> " << dst.id);
      const Clip got = retarget(src.motion, target, mat4_identity());
      REQUIRE(got.frames.size() == want.frames.size());
      const auto g = global_transforms(target, got.frames.back());
      auto pos = [&](const std::vector<Mat4>& gl, const char* part) { return mat4_translation(gl[mt.find(part)]); };
      // The 45-degree knee and the arm raised 60 degrees above the horizontal.
      CHECK(angle_deg(sub(pos(g, "shin.l"), pos(g, "thigh.l")), sub(pos(g, "foot.l"), pos(g, "shin.l"))) ==
            Approx(45.0f).margin(1.5f));
      const Vec3 arm = sub(pos(g, "forearm.l"), pos(g, "upperarm.l"));
      CHECK(std::asin(arm[1] / std::sqrt(dot(arm, arm))) * 57.29578f == Approx(60.0f).margin(2.0f));
      // End effectors within 2 cm of the CMU-named motion's.
      for (const char* part : {"hand.l", "hand.r", "foot.l", "foot.r", "head"}) {
        const Vec3 d = sub(pos(g, part), pos(wg, part));
        INFO(part << " off by " << d[0] / dst.units << " " << d[1] / dst.units << " " << d[2] / dst.units << " m");
        CHECK(std::sqrt(dot(d, d)) / dst.units < 0.02f);
      }
      // Standing in the rest frame: the lowest joint on the target's floor.
      const auto g0 = global_transforms(target, got.frames.front());
      float low = 1e30f;
      for (const Mat4& m : g0) low = std::min(low, m[13]);
      CHECK(std::abs(low - ground) / dst.units < 0.01f);
      ++pairs;
    }
  }
  CHECK(pairs == static_cast<int>(rigfix::specs().size() * all.size()));
}

TEST_CASE("BVH: a Frames: count that disagrees with the data reads the frames present, with a warning", "[character][bvh][motion]") {
  const std::string text = rigfix::bvh(joint_named(), pose());  // 2 frames
  for (const char* claim : {"Frames: 5", "Frames: 1", "Frames: 0"}) {
    std::string t = text;
    t.replace(t.find("Frames: 2"), 9, claim);
    std::vector<std::string> warnings;
    const Motion m = parse_bvh(t, "claim.bvh", [&](const std::string& w) { warnings.push_back(w); });
    CHECK(m.clip.frames.size() == 2);
    REQUIRE(warnings.size() == 1);
    CHECK_THAT(warnings[0], Contains("claim.bvh") && Contains(std::string(claim).substr(8)) && Contains("2 frames"));
  }
  // The right count: no warning.
  std::vector<std::string> none;
  parse_bvh(text, "ok.bvh", [&](const std::string& w) { none.push_back(w); });
  CHECK(none.empty());
  // A partial frame is still an error (a truncated file), whatever the count.
  const std::string cut = text.substr(0, text.size() - 20);
  CHECK_THROWS_WITH(parse_bvh(cut, "cut.bvh", [](const std::string&) {}), Contains("cut.bvh") && Contains("frame"));
  CHECK_THROWS_WITH(parse_bvh(text + " 1 2 3\n", "extra.bvh", [](const std::string&) {}),
                    Contains("more numbers than") && Contains("not a whole frame"));
}

TEST_CASE("BVH: CRLF, tabs, trailing blanks and no End Site read as the tidy file", "[character][bvh][motion]") {
  const std::string text = rigfix::bvh(joint_named(), pose());
  std::string messy;
  for (char c : text) {
    if (c == '\n') messy += " \t\r\n";
    else if (c == ' ') messy += "\t";
    else messy += c;
  }
  // Drop every End Site block.
  std::string bare = text;
  for (std::size_t at; (at = bare.find("End Site")) != std::string::npos;) {
    std::size_t b = bare.rfind('\n', at);
    std::size_t e = bare.find('}', at);
    bare.erase(b, e + 1 - b);
  }
  const Motion a = parse_bvh(text, "tidy.bvh");
  for (const std::string& t : {messy, bare}) {
    const Motion b = parse_bvh(t, "messy.bvh");
    REQUIRE(b.skeleton.names == a.skeleton.names);
    REQUIRE(b.clip.frames.size() == a.clip.frames.size());
    for (std::size_t f = 0; f < a.clip.frames.size(); ++f)
      for (std::size_t j = 0; j < a.skeleton.names.size(); ++j)
        for (int k = 0; k < 4; ++k)
          CHECK(b.clip.frames[f].local[j].rotation[k] == Approx(a.clip.frames[f].local[j].rotation[k]).margin(1e-6));
  }
}

TEST_CASE("BVH: any rotation order, and position channels on any joint", "[character][bvh][motion]") {
  auto rq = [](int axis, float deg) {
    Vec3 v{0, 0, 0};
    v[std::size_t(axis)] = 1.0f;
    return quat_from_axis_angle(v, deg * 0.0174532925f);
  };
  const float ang[3] = {20.0f, -35.0f, 50.0f};
  for (const std::string order : {"XYZ", "YXZ", "ZXY", "ZYX"}) {
    std::string ch;
    for (char c : order) ch += std::string(" ") + c + "rotation";
    std::string vals;
    Quat want{0, 0, 0, 1};
    for (char c : order) {
      vals += " " + std::to_string(ang[c - 'X']);
      want = quat_mul(want, rq(c - 'X', ang[c - 'X']));
    }
    const std::string t = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 1 0\n CHANNELS 6 Xposition Yposition Zposition" + ch +
                          "\n JOINT Knee\n {\n  OFFSET 0 -0.5 0\n  CHANNELS 6 Xposition Yposition Zposition" + ch +
                          "\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 1 0" + vals + " 0.1 -0.4 0.2" + vals + "\n";
    const Motion m = parse_bvh(t, order + ".bvh");
    INFO(order);
    const Transform& k = m.clip.frames[0].local[1];
    for (int c = 0; c < 4; ++c) CHECK(std::abs(k.rotation[c]) == Approx(std::abs(want[c])).margin(1e-5));
    CHECK(k.translation[0] == Approx(0.1f));
    CHECK(k.translation[1] == Approx(-0.4f));
    CHECK(k.translation[2] == Approx(0.2f));
  }
}

TEST_CASE("ASF/AMC: units, axes, partial dofs and clear errors", "[character][asf][motion]") {
  const auto [asf, amc] = asf_amc(asf_named(), pose_without_elbow());
  const std::string a = write("e.asf", asf), m = write("e.amc", amc);
  const Motion mo = load_asf_amc(a, m);
  CHECK(mo.clip.frames.size() == 2);
  CHECK(mo.clip.fps == Approx(120.0f));
  CHECK(mo.skeleton.names[0] == "root");
  // Lengths divided by :units length 0.45: the femur joint sits at the hip (metres).
  const auto g = global_transforms(mo.skeleton, rest_pose(mo.skeleton));
  const Vec3 hip = mat4_translation(g[mo.skeleton.find("lfemur")]);
  CHECK(hip[0] == Approx(0.1f).margin(1e-4));
  CHECK(hip[1] == Approx(0.95f).margin(1e-4));
  // The same with the skeleton found beside the motion (same stem).
  CHECK(load_motion(m).clip.frames.size() == 2);
  // Errors name the file, the line and the field.
  auto asf_with = [&, asf = asf](const std::string& from, const std::string& to) {
    std::string t = asf;
    const std::size_t at = t.find(from);
    REQUIRE(at != std::string::npos);
    t.replace(at, from.size(), to);
    return t;
  };
  CHECK_THROWS_WITH(parse_asf(asf_with("angle deg", "angle grad"), "u.asf"), Contains("u.asf: line") && Contains("grad"));
  CHECK_THROWS_WITH(parse_asf(asf_with("dof rx ry rz", "dof rx rq rz"), "d.asf"), Contains("d.asf: line") && Contains("'rq'"));
  CHECK_THROWS_WITH(parse_asf(asf_with("dof rx ry rz", "dof rx rx rz"), "d2.asf"), Contains("listed twice"));
  CHECK_THROWS_WITH(parse_asf(asf_with("limits (-180.0 180.0)", "limits (30 -30)"), "l.asf"),
                    Contains("l.asf: line") && Contains("lower limit 30 above upper limit -30"));
  CHECK_THROWS_WITH(parse_asf(asf_with("\tlength ", "\tlength -"), "n.asf"), Contains("is negative"));
  CHECK_THROWS_WITH(parse_asf(asf_with("XYZ\n", "XXZ\n"), "o.asf"), Contains("not a permutation of XYZ"));
  CHECK_THROWS_WITH(parse_asf(asf.substr(0, asf.find(":hierarchy")), "h.asf"), Contains("no :hierarchy"));
  CHECK_THROWS_WITH(parse_asf(asf_with("direction", "colour"), "f.asf"), Contains("unknown field 'colour'"));
  CHECK_THROWS_WITH(parse_asf(asf_with("    root lhipjoint", "    root lhipjoint lhipjoint"), "t.asf"),
                    Contains("two parents"));
  CHECK_THROWS_WITH(parse_asf(asf_with("    root lhipjoint", "    ltibia lhipjoint\n    root"), "c.asf"),
                    Contains("c.asf") && Contains("on a cycle"));
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", amc + "lfoo 1 2 3\n", "m.amc"),
                    Contains("m.amc: line") && Contains("unknown bone 'lfoo'"));
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", amc + "lfemur 1 2\n", "m.amc"), Contains("2 values for its 3 dofs"));
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", amc + "lfemur 1 nan 2\n", "m.amc"), Contains("not a finite number"));
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", ":FULLY-SPECIFIED\nlfemur 1 2 3\n", "m.amc"),
                    Contains("before the first frame number"));
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", ":FULLY-SPECIFIED\n", "m.amc"), Contains("no frames"));
  // A frame number past 2^63 - 1 (strtoll saturates it; the next frame's check would overflow).
  CHECK_THROWS_WITH(parse_asf_amc(asf, "s.asf", ":DEGREES\n" + std::string(40, '1') + "\nroot 0 0 0 0 0 0\n2\n", "m.amc"),
                    Contains("m.amc: line 2") && Contains("is out of range"));
  // A bone missing from a frame keeps its previous values.
  const std::string sparse = ":DEGREES\n1\nroot 0 0.45 0 0 0 0\nltibia 45 0 0\n2\nroot 0 0.45 0 0 0 0\n";
  const Motion sp = parse_asf_amc(asf, "s.asf", sparse, "sparse.amc");
  const std::int32_t tib = sp.skeleton.find("ltibia");
  for (int c = 0; c < 4; ++c) CHECK(sp.clip.frames[1].local[tib].rotation[c] == Approx(sp.clip.frames[0].local[tib].rotation[c]));
  CHECK(sp.clip.frames[0].local[tib].rotation[0] == Approx(std::sin(0.3926991f)).margin(1e-5));
}

TEST_CASE("load_motion: clips of character files, and clear errors", "[character][motion]") {
  const Motion m = load_bvh(write("jn_clip2.bvh", rigfix::bvh(joint_named(), pose())));
  const std::string glb = gltf_with_clip(joint_named(), m, "jn_clip2.glb");
  CHECK(load_motion(glb).clip.name == "idle");  // the first clip
  CHECK(load_motion(glb + "#1").clip.name == "wave");
  CHECK(load_motion(glb + "#wave").clip.frames.size() == 2);
  CHECK_THROWS_WITH(load_motion(glb + "#run"), Contains(glb) && Contains("no clip 'run'") && Contains("'idle'") &&
                                                   Contains("'wave'"));
  CHECK_THROWS_WITH(load_motion(glb + "#7"), Contains("no clip '7'"));
  // A character without animations.
  const std::string still = temp_dir() + "/still.glb";
  save_gltf_character(rigfix::character(joint_named()), still);
  CHECK_THROWS_WITH(load_motion(still), Contains(still) && Contains("no animation"));
  // A glTF animation exported without its mesh: the animated nodes are the skeleton.
  {
    const std::string with_mesh = gltf_with_clip(joint_named(), m, "anim_only.gltf");
    nlohmann::json j;
    std::ifstream(with_mesh) >> j;
    j.erase("skins");
    j.erase("meshes");
    for (auto& n : j["nodes"]) {
      n.erase("mesh");
      n.erase("skin");
    }
    std::ofstream(with_mesh) << j.dump();
    const Motion only = load_motion(with_mesh + "#wave");
    CHECK(only.skeleton.num_joints() == m.skeleton.num_joints());
    // The same file through assimp (the FBX / Collada path): the same skeleton and clip.
    ImportOptions io;
    io.allow_no_skin = true;
    const Character via_assimp = load_assimp_character(with_mesh, io);
    CHECK(via_assimp.mesh.num_vertices() == 0);
    CHECK(via_assimp.skeleton.num_joints() == m.skeleton.num_joints());
    REQUIRE(via_assimp.clips.size() == 2);
    CHECK_THROWS_WITH(load_assimp_character(with_mesh), Contains("no skin"));
    const Skeleton target = rigfix::skeleton(spec_named("vrm"));
    const RigMapping mt = map_rig(target);
    const auto a = global_transforms(target, retarget(only, target, mat4_identity()).frames.back());
    const auto b = global_transforms(target, retarget(m, target, mat4_identity()).frames.back());
    for (const char* part : {"hand.l", "hand.r", "foot.l", "foot.r", "head"}) {
      const Vec3 d = sub(mat4_translation(a[mt.find(part)]), mat4_translation(b[mt.find(part)]));
      INFO(part);
      CHECK(std::sqrt(dot(d, d)) < 0.02f);
    }
  }
  // No skin and no animation: nothing to read a skeleton from.
  const std::string bare = write("bare.gltf", R"({"asset":{"version":"2.0"},"nodes":[{"name":"Hips"}],)"
                                              R"("scenes":[{"nodes":[0]}],"scene":0})");
  CHECK_THROWS_WITH(load_motion(bare + "#walk"), Contains("bare.gltf") && Contains("no skin") &&
                                                     Contains("export the animation with its character mesh"));
  CHECK_THROWS_WITH(load_motion(temp_dir() + "/lonely.asf"), Contains("holds a skeleton, not a motion"));
  fs::create_directories(temp_dir() + "/orphan");
  CHECK_THROWS_WITH(load_motion(write("orphan/orphan_x.amc", ":FULLY-SPECIFIED\n1\n")),
                    Contains("orphan_x.amc") && Contains("no ASF skeleton found"));
  CHECK_THROWS_WITH(load_motion("walk.pc2"), Contains("not a motion file"));
  CHECK_THROWS_WITH(load_motion("/nonexistent/walk.bvh"), Contains("/nonexistent/walk.bvh") && Contains("cannot open"));
}

TEST_CASE("the shared CMU walk in every convention drives a shared character like the original", "[character][motion][data]") {
  const fs::path root = fs::path(GATCORE_SOURCE_DIR) / ".." / "shared" / "data";
  const fs::path walk = root / "motion" / "cmu" / "walk.bvh", man = root / "characters" / "quaternius" / "modular_men" / "Casual.glb";
  if (!fs::exists(walk) || !fs::exists(man)) {
    WARN("SKIPPED: the shared data (" << walk.string() << ", " << man.string() << ") is absent");
    SUCCEED();
    return;
  }
  const Motion cmu = load_bvh(walk.string());
  const Character ch = load_character(man.string());
  // CMU BVH names -> each convention's.
  const std::map<std::string, std::string> joint = {
      {"LeftUpLeg", "LeftHip"},       {"LeftLeg", "LeftKnee"},        {"LeftFoot", "LeftAnkle"},
      {"LeftToeBase", "LeftToe"},     {"RightUpLeg", "RightHip"},     {"RightLeg", "RightKnee"},
      {"RightFoot", "RightAnkle"},    {"RightToeBase", "RightToe"},   {"LowerBack", "lowerback"},
      {"Spine", "Chest"},             {"Spine1", "Chest2"},           {"LeftShoulder", "LeftCollar"},
      {"LeftArm", "LeftShoulder"},    {"LeftForeArm", "LeftElbow"},   {"LeftHand", "LeftWrist"},
      {"RightShoulder", "RightCollar"}, {"RightArm", "RightShoulder"}, {"RightForeArm", "RightElbow"},
      {"RightHand", "RightWrist"}};
  const std::map<std::string, std::string> asf = {
      {"Hips", "root"},          {"LHipJoint", "lhipjoint"},     {"LeftUpLeg", "lfemur"},     {"LeftLeg", "ltibia"},
      {"LeftFoot", "lfoot"},     {"LeftToeBase", "ltoes"},       {"RHipJoint", "rhipjoint"},  {"RightUpLeg", "rfemur"},
      {"RightLeg", "rtibia"},    {"RightFoot", "rfoot"},         {"RightToeBase", "rtoes"},   {"LowerBack", "lowerback"},
      {"Spine", "upperback"},    {"Spine1", "thorax"},           {"Neck", "lowerneck"},       {"Neck1", "upperneck"},
      {"Head", "head"},          {"LeftShoulder", "lclavicle"},  {"LeftArm", "lhumerus"},     {"LeftForeArm", "lradius"},
      {"LeftHand", "lwrist"},    {"LeftFingerBase", "lhand"},    {"LeftHandIndex1", "lfingers"}, {"LThumb", "lthumb"},
      {"RightShoulder", "rclavicle"}, {"RightArm", "rhumerus"},  {"RightForeArm", "rradius"}, {"RightHand", "rwrist"},
      {"RightFingerBase", "rhand"}, {"RightHandIndex1", "rfingers"}, {"RThumb", "rthumb"}};
  auto renamed = [&](const std::map<std::string, std::string>* names) {
    Motion m = cmu;
    for (std::size_t j = 0; j < m.skeleton.names.size(); ++j) {
      std::string& n = m.skeleton.names[j];
      if (!names) n = "n" + std::to_string(100 + 13 * j);
      else if (const auto it = names->find(n); it != names->end()) n = it->second;
    }
    return m;
  };
  const std::vector<std::pair<std::string, Motion>> variants = {{"joint-named", renamed(&joint)},
                                                                {"ASF-named", renamed(&asf)},
                                                                {"opaque", renamed(nullptr)},
                                                                {"Z-up", z_up(cmu)}};
  const Mat4 id = mat4_identity();
  const Clip want = retarget(cmu, ch.skeleton, id);
  const RigMapping mt = map_rig(ch.skeleton);
  for (const auto& [label, m] : variants) {
    INFO(label << "\n" << describe_motion_rig(m));
    const Clip got = retarget(m, ch.skeleton, id);
    REQUIRE(got.frames.size() == want.frames.size());
    float worst = 0.0f;
    for (std::size_t f = 0; f < got.frames.size(); f += 7) {
      const auto a = global_transforms(ch.skeleton, got.frames[f]), b = global_transforms(ch.skeleton, want.frames[f]);
      for (const char* part : {"hand.l", "hand.r", "foot.l", "foot.r", "head"}) {
        const std::int32_t j = mt.find(part);
        const Vec3 d = sub(mat4_translation(a[j]), mat4_translation(b[j]));
        worst = std::max(worst, std::sqrt(dot(d, d)));
      }
    }
    // The Quaternius rig is in metres.
    CHECK(worst < 0.02f);
  }
}

TEST_CASE("a shared character's clip (CesiumMan's walk, bound Z-up) drives a fixture rig upright", "[character][motion][data]") {
  const fs::path cesium = fs::path(GATCORE_SOURCE_DIR) / ".." / "shared" / "data" / "characters" / "khronos" / "CesiumMan.glb";
  if (!fs::exists(cesium)) {
    WARN("SKIPPED: the shared data (" << cesium.string() << ") is absent");
    SUCCEED();
    return;
  }
  const Motion m = load_motion(cesium.string() + "#0");
  const MotionRig r = map_motion_rig(m.skeleton);
  INFO(r.frame << "\n" << describe_rig(m.skeleton, r.mapping));
  REQUIRE(r.mapping.humanoid());
  for (const char* id : {"cmu", "quaternius", "rigify"}) {
    const rigfix::Spec dst = spec_named(id);
    const Skeleton target = rigfix::skeleton(dst);
    const RigMapping mt = map_rig(target);
    const Clip clip = retarget(m, target, mat4_identity());
    REQUIRE(clip.frames.size() == m.clip.frames.size());
    for (std::size_t f = 0; f < clip.frames.size(); f += 5) {
      INFO(id << " frame " << f);
      const auto g = global_transforms(target, clip.frames[f]);
      auto y = [&](const char* part) { return g[mt.find(part)][13] / dst.units; };
      // Upright: the head well above the pelvis, the pelvis above the feet.
      CHECK(y("head") - y("pelvis") > 0.5f);
      CHECK(y("pelvis") - std::min(y("foot.l"), y("foot.r")) > 0.6f);
    }
  }
}

TEST_CASE("a dataset keeps an ASF:AMC motion's two paths relative to itself", "[character][motion][dataset]") {
  const auto [asf, amc] = asf_amc(asf_named(), pose());
  const std::string a = write("ds_skel.asf", asf), m = write("ds_walk.amc", amc);
  fs::create_directories(temp_dir() + "/ds");
  const std::string path = temp_dir() + "/ds/dataset.json";
  save_dataset(path, describe_dataset({"procedural:humanoid:0", "procedural:humanoid:1", "procedural:humanoid:2"},
                                      {a + ":" + m}));
  std::ifstream is(path);
  const std::string json{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
  CHECK_THAT(json, Contains("\"../ds_skel.asf:../ds_walk.amc\""));
  const DatasetDescription d = load_dataset(path);
  REQUIRE(d.motions.size() == 1);
  CHECK(d.motions[0] == fs::path(a).lexically_normal().string() + ":" + fs::path(m).lexically_normal().string());
  CHECK(load_motion(d.motions[0]).clip.frames.size() == 2);
}
