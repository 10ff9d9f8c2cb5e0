#include "gatcore/character/data/procedural.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "gatcore/character/rig/vec3.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

constexpr float kPi = 3.14159265358979f;

struct Rng {
  std::mt19937 g;
  float uniform(float lo, float hi) { return lo + (hi - lo) * static_cast<float>(g() >> 8) / static_cast<float>(1u << 24); }
};


struct Builder {
  Character ch;
  std::vector<Vec3> joint_pos;
  std::vector<std::vector<std::pair<int, float>>> infl;
  std::vector<float> pos;

  int joint(const std::string& name, int parent, const Vec3& p) {
    const int j = ch.skeleton.num_joints();
    ch.skeleton.names.push_back(name);
    ch.skeleton.parents.push_back(parent);
    Transform t;
    t.translation = parent >= 0 ? sub(p, joint_pos[parent]) : p;
    ch.skeleton.rest_local.push_back(t);
    Mat4 ibm = mat4_identity();
    ibm[12] = -p[0];
    ibm[13] = -p[1];
    ibm[14] = -p[2];
    ch.skeleton.inverse_bind.push_back(ibm);
    ch.skeleton.root_parent.push_back(mat4_identity());
    joint_pos.push_back(p);
    return j;
  }

  int vertex(const Vec3& p, std::vector<std::pair<int, float>> w) {
    pos.insert(pos.end(), p.begin(), p.end());
    infl.push_back(std::move(w));
    return static_cast<int>(infl.size()) - 1;
  }

  // A tube swept along points[0..k] (k segments; segment i is bound to
  // bones[i]) with radii per point. Weights blend into the next bone over the
  // last `blend` of a segment and from the previous over the first `blend`.
  void tube(const std::vector<Vec3>& points, const std::vector<int>& bones, const std::vector<float>& radii,
            const Vec3& ref, int segments, int rings_per_bone, float blend, bool caps) {
    const int nseg = static_cast<int>(bones.size());
    std::vector<int> ring_start;
    std::vector<std::vector<std::pair<int, float>>> ring_w;
    std::vector<Vec3> centres;
    for (int s = 0; s < nseg; ++s) {
      const Vec3 a = points[s], b = points[s + 1];
      const Vec3 d = normalise(sub(b, a));
      Vec3 e1 = normalise(cross(d, ref));
      if (e1[0] == 0.0f && e1[1] == 0.0f && e1[2] == 0.0f) e1 = normalise(cross(d, Vec3{0.3f, 0.5f, 0.8f}));
      const Vec3 e2 = cross(d, e1);
      const int rings = rings_per_bone + (s == nseg - 1 ? 1 : 0);
      for (int r = 0; r < rings; ++r) {
        const float t = static_cast<float>(r) / rings_per_bone;
        const Vec3 c = add(a, scale(sub(b, a), t));
        const float rad = radii[s] + t * (radii[s + 1] - radii[s]);
        std::vector<std::pair<int, float>> w;
        float next = 0.0f, prev = 0.0f;
        if (s + 1 < nseg && t > 1.0f - blend) next = 0.5f * (t - (1.0f - blend)) / blend;
        if (s > 0 && t < blend) prev = 0.5f * (blend - t) / blend;
        w.push_back({bones[s], 1.0f - next - prev});
        if (next > 0.0f) w.push_back({bones[s + 1], next});
        if (prev > 0.0f) w.push_back({bones[s - 1], prev});
        ring_start.push_back(static_cast<int>(infl.size()));
        for (int k = 0; k < segments; ++k) {
          const float ang = 2.0f * kPi * k / segments;
          vertex(add(c, add(scale(e1, rad * std::cos(ang)), scale(e2, rad * std::sin(ang)))), w);
        }
        ring_w.push_back(w);
        centres.push_back(c);
      }
    }
    auto& tris = ch.mesh.triangles;
    for (std::size_t r = 0; r + 1 < ring_start.size(); ++r)
      for (int k = 0; k < segments; ++k) {
        const int a = ring_start[r] + k, b = ring_start[r] + (k + 1) % segments, c = ring_start[r + 1] + k,
                  d = ring_start[r + 1] + (k + 1) % segments;
        tris.insert(tris.end(), {a, b, c, b, d, c});
      }
    if (caps) {
      for (int end = 0; end < 2; ++end) {
        const std::size_t r = end ? ring_start.size() - 1 : 0;
        const int centre = vertex(centres[r], ring_w[r]);
        for (int k = 0; k < segments; ++k) {
          const int a = ring_start[r] + k, b = ring_start[r] + (k + 1) % segments;
          if (end) tris.insert(tris.end(), {centre, a, b});
          else tris.insert(tris.end(), {centre, b, a});
        }
      }
    }
  }
};

}  // namespace

Character procedural_character(const ProceduralOptions& opt) {
  GATCORE_CHECK(opt.ring_segments >= 3 && opt.rings_per_bone >= 1, "procedural_character: ring_segments >= 3 and ",
                "rings_per_bone >= 1 required, got ", opt.ring_segments, ", ", opt.rings_per_bone);
  GATCORE_CHECK(opt.blend > 0.0f && opt.blend <= 0.5f, "procedural_character: blend must be in (0, 0.5], got ", opt.blend);
  Rng rng{std::mt19937(opt.seed)};
  Builder B;
  const int S = opt.ring_segments, R = opt.rings_per_bone;
  const float bl = opt.blend;
  if (opt.kind == ProceduralKind::humanoid) {
    const float h = rng.uniform(1.55f, 1.95f), girth = rng.uniform(0.8f, 1.25f), arm = rng.uniform(0.9f, 1.1f);
    const float leg = 0.48f * h, hip_w = 0.09f * h * girth, sh_w = 0.11f * h;
    const int hips = B.joint("Hips", -1, {0.0f, leg + 0.04f * h, 0.0f});
    const int abdomen = B.joint("Abdomen", hips, {0.0f, leg + 0.14f * h, 0.0f});
    const int chest = B.joint("Chest", abdomen, {0.0f, leg + 0.27f * h, 0.0f});
    const int neck = B.joint("Neck", chest, {0.0f, leg + 0.39f * h, 0.0f});
    const int head = B.joint("Head", neck, {0.0f, leg + 0.42f * h, 0.01f * h});
    const Vec3 head_top = {0.0f, h, 0.01f * h};
    int up[2], lo[2], hand[2], uleg[2], lleg[2], foot[2];
    Vec3 hand_tip[2], toe[2];
    for (int side = 0; side < 2; ++side) {
      const float sx = side == 0 ? 1.0f : -1.0f;  // +x is the character's left (facing +z)
      const char* suf = side == 0 ? ".L" : ".R";
      const int sh = B.joint(std::string("Shoulder") + suf, chest, {sx * 0.03f * h, leg + 0.36f * h, 0.0f});
      up[side] = B.joint(std::string("UpperArm") + suf, sh, {sx * sh_w, leg + 0.36f * h, 0.0f});
      lo[side] = B.joint(std::string("LowerArm") + suf, up[side], {sx * (sh_w + 0.17f * h * arm), leg + 0.36f * h, -0.01f * h});
      hand[side] = B.joint(std::string("Hand") + suf, lo[side], {sx * (sh_w + 0.32f * h * arm), leg + 0.36f * h, 0.0f});
      hand_tip[side] = {sx * (sh_w + 0.41f * h * arm), leg + 0.36f * h, 0.0f};
      uleg[side] = B.joint(std::string("UpperLeg") + suf, hips, {sx * hip_w, leg, 0.0f});
      lleg[side] = B.joint(std::string("LowerLeg") + suf, uleg[side], {sx * hip_w, 0.27f * h, 0.01f * h});
      foot[side] = B.joint(std::string("Foot") + suf, lleg[side], {sx * hip_w, 0.045f * h, 0.0f});
      toe[side] = {sx * hip_w, 0.025f * h, 0.13f * h};
    }
    const float t = 0.1f * h * girth;
    B.tube({B.joint_pos[hips], B.joint_pos[abdomen], B.joint_pos[chest], B.joint_pos[neck], B.joint_pos[head], head_top},
           {hips, abdomen, chest, neck, head}, {1.05f * t, t, 1.1f * t, 0.4f * t, 0.75f * t, 0.5f * t},
           {0.0f, 0.0f, 1.0f}, S, R, bl, true);
    const float a = 0.035f * h * girth, l = 0.06f * h * girth;
    for (int side = 0; side < 2; ++side) {
      B.tube({B.joint_pos[up[side]], B.joint_pos[lo[side]], B.joint_pos[hand[side]], hand_tip[side]},
             {up[side], lo[side], hand[side]}, {1.1f * a, 0.85f * a, 0.7f * a, 0.5f * a}, {0.0f, 0.0f, 1.0f}, S, R, bl, true);
      B.tube({B.joint_pos[uleg[side]], B.joint_pos[lleg[side]], B.joint_pos[foot[side]], toe[side]},
             {uleg[side], lleg[side], foot[side]}, {l, 0.75f * l, 0.55f * l, 0.45f * l}, {1.0f, 0.0f, 0.0f}, S, R, bl, true);
    }
    if (opt.garments) {
      for (int side = 0; side < 2; ++side) {  // sleeves: upper arm to mid forearm
        const Vec3 mid = scale(add(B.joint_pos[lo[side]], B.joint_pos[hand[side]]), 0.5f);
        B.tube({B.joint_pos[up[side]], B.joint_pos[lo[side]], mid}, {up[side], lo[side]},
               {1.45f * a, 1.3f * a, 1.2f * a}, {0.0f, 0.0f, 1.0f}, S, R, bl, false);
      }
      if (rng.uniform(0.0f, 1.0f) < 0.5f) {
        // Skirt: a cone from the waist, each column weighted to the hips and
        // the upper leg on its side.
        const float top = B.joint_pos[hips][1] + 0.02f * h, bottom = 0.3f * h;
        const float r0 = 1.25f * t, r1 = rng.uniform(1.8f, 2.6f) * t;
        const int rings = 2 * R + 1, base = static_cast<int>(B.infl.size());
        for (int r = 0; r < rings; ++r) {
          const float u = static_cast<float>(r) / (rings - 1);
          for (int k = 0; k < S; ++k) {
            const float ang = 2.0f * kPi * k / S, x = std::cos(ang), rad = r0 + u * (r1 - r0);
            const int side = x >= 0.0f ? 0 : 1;
            const float wl = u * (0.5f + 0.5f * std::abs(x));
            B.vertex({rad * x, top + u * (bottom - top), rad * std::sin(ang)}, {{hips, 1.0f - wl}, {uleg[side], wl}});
          }
        }
        for (int r = 0; r + 1 < rings; ++r)
          for (int k = 0; k < S; ++k) {
            const int p = base + r * S + k, q = base + r * S + (k + 1) % S;
            B.ch.mesh.triangles.insert(B.ch.mesh.triangles.end(), {p, p + S, q, q, p + S, q + S});
          }
      } else {
        for (int side = 0; side < 2; ++side)  // loose trousers
          B.tube({B.joint_pos[uleg[side]], B.joint_pos[lleg[side]], B.joint_pos[foot[side]]}, {uleg[side], lleg[side]},
                 {1.35f * l, 1.25f * l, 1.15f * l}, {1.0f, 0.0f, 0.0f}, S, R, bl, false);
      }
    }
  } else {
    const float len = rng.uniform(1.0f, 1.6f), hgt = rng.uniform(0.5f, 0.9f), girth = rng.uniform(0.8f, 1.3f);
    const float half = 0.5f * len, w = 0.12f * len * girth;
    const int hips = B.joint("Hips", -1, {0.0f, hgt, -0.35f * len});
    const int spine = B.joint("Spine", hips, {0.0f, hgt + 0.02f, 0.0f});
    const int chest = B.joint("Chest", spine, {0.0f, hgt + 0.03f, 0.35f * len});
    const int neck = B.joint("Neck", chest, {0.0f, hgt + 0.15f * len, half});
    const int head = B.joint("Head", neck, {0.0f, hgt + 0.25f * len, half + 0.1f * len});
    const Vec3 snout = {0.0f, hgt + 0.2f * len, half + 0.3f * len};
    const int tail1 = B.joint("Tail1", hips, {0.0f, hgt, -half});
    const int tail2 = B.joint("Tail2", tail1, {0.0f, hgt - 0.05f * len, -half - 0.15f * len});
    const Vec3 tail_tip = {0.0f, hgt - 0.15f * len, -half - 0.35f * len};
    B.tube({B.joint_pos[hips], B.joint_pos[spine], B.joint_pos[chest], B.joint_pos[neck], B.joint_pos[head], snout},
           {hips, spine, chest, neck, head}, {1.1f * w, w, 1.1f * w, 0.6f * w, 0.55f * w, 0.3f * w}, {1.0f, 0.0f, 0.0f},
           S, R, bl, true);
    B.tube({B.joint_pos[hips], B.joint_pos[tail1], B.joint_pos[tail2], tail_tip}, {hips, tail1, tail2},
           {0.3f * w, 0.25f * w, 0.15f * w, 0.05f * w}, {1.0f, 0.0f, 0.0f}, S, R, bl, true);
    for (int front = 0; front < 2; ++front)
      for (int side = 0; side < 2; ++side) {
        const float sx = side == 0 ? 1.0f : -1.0f, z = front ? 0.33f * len : -0.33f * len;
        const std::string n = std::string(front ? "Front" : "Back") + (side == 0 ? "Leg.L" : "Leg.R");
        const int parent = front ? chest : hips;
        const int upper = B.joint("Upper" + n, parent, {sx * 0.7f * w, hgt - 0.05f * len, z});
        const int lower = B.joint("Lower" + n, upper, {sx * 0.7f * w, 0.5f * hgt, z + (front ? 0.02f : -0.04f) * len});
        const int foot = B.joint("Foot" + n, lower, {sx * 0.7f * w, 0.06f * hgt, z});
        const Vec3 toe = {sx * 0.7f * w, 0.0f, z + 0.06f * len};
        B.tube({B.joint_pos[upper], B.joint_pos[lower], B.joint_pos[foot], toe}, {upper, lower, foot},
               {0.45f * w, 0.3f * w, 0.22f * w, 0.2f * w}, {1.0f, 0.0f, 0.0f}, S, R, bl, true);
      }
  }
  // Ground the character (lowest point at y = 0).
  float ground = B.pos[1];
  for (std::size_t v = 0; v < B.pos.size() / 3; ++v) ground = std::min(ground, B.pos[3 * v + 1]);
  for (std::size_t v = 0; v < B.pos.size() / 3; ++v) B.pos[3 * v + 1] -= ground;
  Skeleton& sk = B.ch.skeleton;
  for (std::int32_t j = 0; j < sk.num_joints(); ++j) {
    if (sk.parents[j] < 0) sk.rest_local[j].translation[1] -= ground;
    sk.inverse_bind[j][13] += ground;
  }
  Character& ch = B.ch;
  ch.name = opt.kind == ProceduralKind::humanoid ? "procedural humanoid " + std::to_string(opt.seed)
                                                 : "procedural creature " + std::to_string(opt.seed);
  ch.mesh.positions = std::move(B.pos);
  ch.mesh.weights.ptr.assign(1, 0);
  for (auto& l : B.infl) {
    std::sort(l.begin(), l.end());
    for (const auto& [j, w] : l)
      if (w > 0.0f) {
        ch.mesh.weights.joint.push_back(j);
        ch.mesh.weights.weight.push_back(w);
      }
    ch.mesh.weights.ptr.push_back(static_cast<std::int64_t>(ch.mesh.weights.joint.size()));
  }
  ch.welded_from_file.resize(static_cast<std::size_t>(ch.mesh.num_vertices()));
  for (std::size_t v = 0; v < ch.welded_from_file.size(); ++v) ch.welded_from_file[v] = static_cast<std::int32_t>(v);
  // The object is named like the mesh node save_gltf_character writes.
  ch.primitives.push_back({0, 0, 0, ch.name.empty() ? "character" : ch.name, 0, ch.mesh.num_vertices()});
  ch.joint_nodes.assign(static_cast<std::size_t>(sk.num_joints()), -1);
  sk.validate(ch.name.c_str());
  ch.mesh.validate(sk.num_joints(), ch.name.c_str());
  return ch;
}

std::string procedural_swing_bvh(int frames) {
  GATCORE_CHECK(frames >= 1 && frames <= 100000, "procedural_swing_bvh: frames must be in [1, 100000], got ", frames);
  // Joint, parent depth layout and offsets of a compact CMU-named skeleton.
  struct J {
    const char* name;
    int depth;
    float x, y, z;
    bool end;  // followed by an End Site at (ex, ey, ez)
    float ex, ey, ez;
  };
  const J joints[] = {
      {"LeftUpLeg", 1, 1.2f, -0.4f, 0, false, 0, 0, 0},  {"LeftLeg", 2, 0, -7, 0, false, 0, 0, 0},
      {"LeftFoot", 3, 0, -7, 0, true, 0, -1, 2},          {"RightUpLeg", 1, -1.2f, -0.4f, 0, false, 0, 0, 0},
      {"RightLeg", 2, 0, -7, 0, false, 0, 0, 0},          {"RightFoot", 3, 0, -7, 0, true, 0, -1, 2},
      {"LowerBack", 1, 0, 1, 0, false, 0, 0, 0},          {"Spine", 2, 0, 2, 0, false, 0, 0, 0},
      {"Spine1", 3, 0, 2, 0, false, 0, 0, 0},             {"Neck", 4, 0, 2, 0, false, 0, 0, 0},
      {"Head", 5, 0, 1.5f, 0, true, 0, 2, 0},             {"LeftShoulder", 4, 0.5f, 1.6f, 0, false, 0, 0, 0},
      {"LeftArm", 5, 1.5f, 0, 0, false, 0, 0, 0},         {"LeftForeArm", 6, 5, 0, 0, false, 0, 0, 0},
      {"LeftHand", 7, 4.5f, 0, 0, true, 1.5f, 0, 0},      {"RightShoulder", 4, -0.5f, 1.6f, 0, false, 0, 0, 0},
      {"RightArm", 5, -1.5f, 0, 0, false, 0, 0, 0},       {"RightForeArm", 6, -5, 0, 0, false, 0, 0, 0},
      {"RightHand", 7, -4.5f, 0, 0, true, -1.5f, 0, 0},
  };
  constexpr int kJoints = sizeof(joints) / sizeof(joints[0]);
  std::string out = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
                    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation\n";
  auto indent = [](int d) { return std::string(2 * static_cast<std::size_t>(d), ' '); };
  auto num = [](float v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", static_cast<double>(v));
    return std::string(b);
  };
  int open = 1;  // braces open below ROOT
  for (int j = 0; j < kJoints; ++j) {
    const J& jt = joints[j];
    while (open > jt.depth) out += indent(--open) + "}\n";
    out += indent(open) + "JOINT " + jt.name + "\n" + indent(open) + "{\n";
    out += indent(open + 1) + "OFFSET " + num(jt.x) + " " + num(jt.y) + " " + num(jt.z) + "\n";
    out += indent(open + 1) + "CHANNELS 3 Zrotation Yrotation Xrotation\n";
    ++open;
    if (jt.end)
      out += indent(open) + "End Site\n" + indent(open) + "{\n" + indent(open + 1) + "OFFSET " + num(jt.ex) + " " +
             num(jt.ey) + " " + num(jt.ez) + "\n" + indent(open) + "}\n";
  }
  while (open > 0) out += indent(--open) + "}\n";
  out += "MOTION\nFrames: " + std::to_string(frames) + "\nFrame Time: 0.0333333\n";
  // Channel values per frame (degrees; Z Y X order per joint after the
  // root's 6), as named columns.
  const double kPi = 3.14159265358979323846;
  std::vector<double> v(6 + 3 * kJoints);
  auto set = [&](const char* joint, int axis /*0 Z, 1 Y, 2 X*/, double value) {
    for (int j = 0; j < kJoints; ++j)
      if (!std::strcmp(joints[j].name, joint)) v[static_cast<std::size_t>(6 + 3 * j + axis)] = value;
  };
  for (int f = 0; f < frames; ++f) {
    std::fill(v.begin(), v.end(), 0.0);
    const double s = std::sin(2.0 * kPi * f / 24.0);
    v[1] = 15.5 + 0.3 * std::abs(s);  // hips bob twice per cycle
    v[2] = 0.6 * f;                   // and move forward
    set("LeftUpLeg", 2, 30 * s);
    set("LeftLeg", 2, -35 * std::max(0.0, -s));  // knee bends on the back swing
    set("RightUpLeg", 2, -30 * s);
    set("RightLeg", 2, -35 * std::max(0.0, s));
    set("Spine", 1, 8 * s);
    set("Neck", 1, -6 * s);
    set("LeftArm", 0, -60);  // arms lowered from the T-pose
    set("LeftArm", 1, 25 * s);
    set("LeftForeArm", 1, -40 - 20 * s);  // elbows bend about Y
    set("RightArm", 0, 60);
    set("RightArm", 1, -25 * s);
    set("RightForeArm", 1, 40 - 20 * s);
    for (std::size_t c = 0; c < v.size(); ++c) {
      char b[32];
      std::snprintf(b, sizeof b, "%s%.4f", c ? " " : "", v[c]);
      out += b;
    }
    out += "\n";
  }
  return out;
}

}  // namespace gatcore::character
