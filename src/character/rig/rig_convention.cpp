// Recognising a skeleton's naming convention and mapping its joints onto the
// canonical humanoid body (see rig_convention.hpp).
#include "gatcore/character/rig/rig_convention.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <unordered_map>

#include "gatcore/character/rig/pose.hpp"
#include "gatcore/error.hpp"
#include "src/character/rig/rig_tables.hpp"

namespace gatcore::character {

using namespace rig_detail;

namespace {

// A joint that no table names but whose name says what it is for: IK
// targets, poles, twist / roll segments, end bones, sockets. These are left
// alone when retargeting and never count as a missing limb.
bool looks_like_helper(const std::string& key) {
  auto has = [&](const char* x) { return key.find(x) != std::string::npos; };
  auto starts = [&](const char* x) { return key.rfind(x, 0) == 0; };
  auto ends = [&](const std::string& x) { return key.size() >= x.size() && key.compare(key.size() - x.size(), x.size(), x) == 0; };
  if (starts("ik") || starts("mch") || starts("ctrl") || starts("control") || starts("pole") || starts("vis")) return true;
  for (const char* x : {"twist", "roll", "pole", "target", "helper", "nub", "socket", "slot", "weapon", "metacarpal",
                        "carpal", "corrective", "attach", "prop", "endsite"})
    if (has(x)) return true;
  for (const std::string side : {"", "l", "r"})
    if (ends("ik" + side) || ends("end" + side) || ends("ctrl" + side)) return true;
  return key == "pt" || key == "ptl" || key == "ptr";
}

// The longest prefix every joint name shares that ends in a separator
// ("Skeleton1_" of OptiTrack's "Skeleton1_Hip"), unless it is a whole name.
std::size_t common_prefix(const Skeleton& s) {
  if (s.num_joints() < 2) return 0;
  std::size_t n = s.names[0].size();
  for (const std::string& name : s.names) {
    std::size_t i = 0;
    while (i < n && i < name.size() && name[i] == s.names[0][i]) ++i;
    n = i;
  }
  while (n > 0) {
    const char c = s.names[0][n - 1];
    if (c == '_' || c == ':' || c == '|' || c == ' ' || c == '-' || c == '.') break;
    --n;
  }
  for (const std::string& name : s.names)
    if (name.size() <= n) return 0;
  return n;
}

std::vector<Vec3> world_positions(const Skeleton& s, const Mat4& bind_to_world) {
  std::vector<Vec3> p(static_cast<std::size_t>(s.num_joints()));
  for (std::int32_t j = 0; j < s.num_joints(); ++j) p[j] = mat4_translation(mul(bind_to_world, inverse(s.inverse_bind[j])));
  return p;
}

std::int32_t depth(const Skeleton& s, std::int32_t j) {
  std::int32_t d = 0;
  for (; s.parents[j] >= 0; j = s.parents[j]) ++d;
  return d;
}

// The part an alias names: a body part itself, or any convention's joint name.
std::string alias_part(const std::string& target) {
  const auto& parts = body_part_names();
  if (std::find(parts.begin(), parts.end(), target) != parts.end()) return target;
  // Chain parts may be named with an index ("spine2"); the index is recomputed.
  for (const char* base : {"spine", "neck"})
    if (target.rfind(base, 0) == 0 && target.size() > std::string(base).size() &&
        std::all_of(target.begin() + static_cast<long>(std::string(base).size()), target.end(), ::isdigit))
      return base;
  // A joint name as normalise_bone_name leaves it ("upleg.l" from
  // "LeftUpLeg"): try the side spellings the tables use.
  std::vector<std::string> keys = {rig_key(target)};
  if (target.size() > 2 && target[target.size() - 2] == '.') {
    const std::string b = rig_key(target.substr(0, target.size() - 2));
    const char s = target.back();
    const std::string word = s == 'l' ? "left" : "right";
    keys = {word + b, b + s, std::string(1, s) + b, "bip01" + std::string(1, s) + b, b + word};
  }
  for (const std::string& k : keys)
    for (const RigTable& t : rig_tables())
      for (const RigEntry& e : t.entries)
        if (e.key == k) return e.part;
  return "";
}

}  // namespace

const std::vector<std::string>& required_humanoid_parts() {
  static const std::vector<std::string> r = {"pelvis", "thigh.l", "thigh.r", "shin.l", "shin.r",
                                             "upperarm.l", "upperarm.r", "forearm.l", "forearm.r"};
  return r;
}

const std::vector<std::string>& body_part_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n = {"pelvis", "spine", "neck", "head"};
    for (const char* side : {".l", ".r"}) {
      for (const char* p : {"clavicle", "upperarm", "forearm", "hand", "thigh", "shin", "foot", "toe"})
        n.push_back(std::string(p) + side);
      for (const char* f : {"thumb", "index", "middle", "ring", "pinky"}) n.push_back(std::string(f) + side);
    }
    return n;
  }();
  return names;
}

std::vector<std::string> known_rig_conventions() {
  std::vector<std::string> n;
  for (const RigTable& t : rig_tables()) n.push_back(t.name);
  return n;
}

std::int32_t RigMapping::find(const std::string& part) const {
  for (std::size_t j = 0; j < body.size(); ++j)
    if (body[j] == part) return static_cast<std::int32_t>(j);
  return -1;
}

RigMapping map_rig(const Skeleton& s, const BoneAliases& aliases, const Mat4& bind_to_world) {
  const std::int32_t J = s.num_joints();
  const std::size_t cut = common_prefix(s);
  std::vector<std::string> keys(static_cast<std::size_t>(J));
  std::vector<std::string> lower(static_cast<std::size_t>(J));
  for (std::int32_t j = 0; j < J; ++j) {
    keys[j] = rig_key(s.names[j].substr(cut));
    for (char c : s.names[j]) lower[j].push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  // The table that explains most joints (body parts, then signature names,
  // then table order: UE4 before UE5, ...).
  const auto& tables = rig_tables();
  std::vector<std::unordered_map<std::string, std::string>> index(tables.size());
  std::size_t best = tables.size();
  int best_score = 0, best_sig = -1;
  for (std::size_t t = 0; t < tables.size(); ++t) {
    for (const RigEntry& e : tables[t].entries) index[t].emplace(e.key, e.part);
    int score = 0, sig = 0;
    for (std::int32_t j = 0; j < J; ++j) {
      const auto it = index[t].find(keys[j]);
      if (it != index[t].end() && it->second != "-" && it->second != "^") ++score;
    }
    for (const std::string& k : tables[t].signature)
      for (std::int32_t j = 0; j < J; ++j)
        if (k[0] == '~' ? lower[j].find(k.substr(1)) != std::string::npos : keys[j] == k) {
          ++sig;
          break;
        }
    if (score > best_score || (score == best_score && score > 0 && sig > best_sig)) {
      best = t;
      best_score = score;
      best_sig = sig;
    }
  }

  RigMapping m;
  m.body.assign(static_cast<std::size_t>(J), "");
  m.role.assign(static_cast<std::size_t>(J), JointRole::other);
  m.by_structure.assign(static_cast<std::size_t>(J), 0);
  std::vector<std::uint8_t> forced(static_cast<std::size_t>(J), 0);
  auto assign = [&](std::int32_t j, const std::string& part) {
    if (part == "-") m.role[j] = JointRole::helper;
    else if (part == "^") m.role[j] = JointRole::root;
    else {
      m.role[j] = JointRole::body;
      m.body[j] = part;
    }
  };
  for (std::int32_t j = 0; j < J; ++j) {
    const std::string n = normalise_bone_name(s.names[j]);
    const std::string a = aliases.apply(n);
    if (a != n) {
      const std::string part = alias_part(a);
      if (!part.empty()) {
        assign(j, part);
        forced[j] = 1;
        continue;
      }
    }
    bool found = false;
    if (best < tables.size())
      if (const auto it = index[best].find(keys[j]); it != index[best].end()) {
        assign(j, it->second);
        found = true;
      }
    // A name the chosen table lacks but another convention knows (mixed rigs).
    for (std::size_t t = 0; !found && t < tables.size(); ++t)
      if (const auto it = index[t].find(keys[j]); it != index[t].end()) {
        assign(j, it->second);
        found = true;
      }
    if (!found && looks_like_helper(keys[j])) m.role[j] = JointRole::helper;
  }
  // Names shifted by one bone: a rig mixing joint names (LeftShoulder = the
  // upper arm) with bone names (LeftArm = the upper arm, LeftShoulder = the
  // collar) claims the upper arm twice on one chain. The deeper joint is the
  // upper arm (the forearm hangs under it); the one above it is the collar.
  for (const char* side : {".l", ".r"}) {
    std::vector<std::int32_t> claims;
    for (std::int32_t j = 0; j < J; ++j)
      if (m.role[j] == JointRole::body && !forced[j] && m.body[j] == std::string("upperarm") + side) claims.push_back(j);
    if (claims.size() != 2) continue;
    std::int32_t hi = claims[0], lo = claims[1];
    if (depth(s, hi) > depth(s, lo)) std::swap(hi, lo);
    bool above = false;
    for (std::int32_t p = s.parents[lo]; p >= 0 && !above; p = s.parents[p]) above = p == hi;
    bool collar = false;
    for (std::int32_t j = 0; j < J; ++j) collar = collar || m.body[j] == std::string("clavicle") + side;
    if (above && !collar) m.body[hi] = std::string("clavicle") + side;
  }
  // One joint per part (chains: one per link): an alias wins, then the
  // joint nearest the root; the others are left alone like helpers.
  {
    std::map<std::string, std::int32_t> owner;
    for (int pass = 0; pass < 2; ++pass)
      for (std::int32_t j = 0; j < J; ++j) {
        if (m.role[j] != JointRole::body || is_chain_part(m.body[j]) || forced[j] != (pass == 0)) continue;
        if (!owner.emplace(m.body[j], j).second) {
          m.role[j] = JointRole::helper;
          m.body[j].clear();
        }
      }
  }
  // Number the chains from the root outwards; fingers keep three links (a
  // fourth is the tip's end bone).
  {
    std::map<std::string, std::vector<std::int32_t>> chains;
    for (std::int32_t j = 0; j < J; ++j)
      if (m.role[j] == JointRole::body && is_chain_part(m.body[j])) chains[m.body[j]].push_back(j);
    for (auto& [base, joints] : chains) {
      std::stable_sort(joints.begin(), joints.end(),
                       [&](std::int32_t a, std::int32_t b) { return depth(s, a) < depth(s, b); });
      const bool finger = base != "spine" && base != "neck";
      for (std::size_t i = 0; i < joints.size(); ++i) {
        const std::int32_t j = joints[i];
        if (finger && i >= 3) {
          m.role[j] = JointRole::helper;
          m.body[j].clear();
          continue;
        }
        const std::string num = std::to_string(i + 1);
        m.body[j] = finger ? base.substr(0, base.size() - 2) + num + base.substr(base.size() - 2) : base + num;
      }
    }
  }
  // A convention is named only when its table explains at least three
  // joints, a limb among them (a quadruped's Spine/Neck/Head say nothing).
  bool limb = false;
  for (std::int32_t j = 0; j < J; ++j)
    if (best < tables.size() && m.role[j] == JointRole::body && !forced[j] && m.body[j].size() > 2 &&
        m.body[j][m.body[j].size() - 2] == '.' && index[best].count(keys[j]))
      limb = true;
  std::string convention = best < tables.size() && best_score >= 3 && limb ? tables[best].name : "";
  auto missing = [&] {
    std::vector<std::string> out;
    for (const std::string& p : required_humanoid_parts())
      if (m.find(p) < 0) out.push_back(p);
    return out;
  };
  if (!missing().empty() && J > 0) {
    const std::vector<std::uint8_t> before = m.by_structure;
    propose_by_structure(s, world_positions(s, bind_to_world), m);
    if (m.by_structure != before) convention = convention.empty() ? "structural" : convention + " + structural";
  }
  m.missing = missing();
  // Older Quaternius packs hang the feet off the root (IK bones).
  if (convention == "Quaternius") {
    const std::int32_t foot = m.find("foot.l"), shin = m.find("shin.l");
    bool under = false;
    for (std::int32_t p = foot; p >= 0 && !under; p = s.parents[p]) under = p == shin;
    if (foot >= 0 && shin >= 0 && !under) convention = "Quaternius (older: feet on the root)";
  }
  m.convention = convention.empty() ? "unknown" : convention;
  return m;
}

std::string unmapped_joint_list(const Skeleton& s, const RigMapping& m, std::size_t limit) {
  // Limb-looking names first: those are what an --alias has to name.
  auto limb = [](const std::string& name) {
    const std::string k = rig_key(name);
    for (const char* x : {"leg", "arm", "thigh", "shin", "calf", "foot", "hand", "shoulder", "hip", "knee", "elbow",
                          "pelvis", "clav"})
      if (k.find(x) != std::string::npos) return true;
    return false;
  };
  std::string out;
  std::size_t n = 0;
  for (int pass = 0; pass < 2; ++pass)
    for (std::int32_t j = 0; j < s.num_joints(); ++j) {
      if (m.role[j] != JointRole::other || limb(s.names[j]) != (pass == 0)) continue;
      if (n++ == limit) {
        out += ", ...";
        return out;
      }
      out += (n > 1 ? ", '" : "'") + s.names[j] + "'";
    }
  return out.empty() ? "(none)" : out;
}

std::string describe_rig(const Skeleton& s, const RigMapping& m) {
  std::string out = "convention " + m.convention + (m.humanoid() ? " (humanoid)" : "") + "\n";
  if (!m.missing.empty()) {
    out += "missing    ";
    for (std::size_t i = 0; i < m.missing.size(); ++i) out += (i ? ", " : "") + m.missing[i];
    out += " (not a humanoid to retarget onto; --alias JOINT=PART maps a joint by hand)\n";
  }
  out += "body map\n";
  // One row per part, left | right; chains in link order; fingers counted.
  char line[1024];
  auto names_of = [&](const std::string& base, const std::string& side) {
    std::string n;
    for (int i = 0; i <= 9; ++i) {
      const std::string part = base + (i ? std::to_string(i) : std::string()) + side;
      const std::int32_t j = m.find(part);
      if (j < 0) continue;
      n += (n.empty() ? "" : ", ") + s.names[j] + (m.by_structure[j] ? "*" : "");
    }
    return n;
  };
  bool structural = false;
  for (std::uint8_t b : m.by_structure) structural = structural || b;
  for (const char* base : {"pelvis", "spine", "neck", "head"}) {
    const std::string n = names_of(base, "");
    if (!n.empty()) {
      std::snprintf(line, sizeof line, "  %-9s %s\n", base, n.c_str());
      out += line;
    }
  }
  auto row = [&](const char* label, const std::string& l, const std::string& r) {
    if (l.empty() && r.empty()) return;
    std::snprintf(line, sizeof line, "  %-9s %s | %s\n", label, l.empty() ? "-" : l.c_str(), r.empty() ? "-" : r.c_str());
    out += line;
  };
  for (const char* base : {"clavicle", "upperarm", "forearm", "hand"}) row(base, names_of(base, ".l"), names_of(base, ".r"));
  std::string fl, fr;
  for (const char* f : {"thumb", "index", "middle", "ring", "pinky"})
    for (const char* side : {".l", ".r"}) {
      int n = 0;
      for (int i = 1; i <= 3; ++i) n += m.find(f + std::to_string(i) + side) >= 0;
      std::string& dst = side[1] == 'l' ? fl : fr;
      if (n) dst += (dst.empty() ? "" : ", ") + std::string(f) + " " + std::to_string(n);
    }
  row("fingers", fl, fr);
  for (const char* base : {"thigh", "shin", "foot", "toe"}) row(base, names_of(base, ".l"), names_of(base, ".r"));
  if (structural) out += "  (* proposed by the structural fallback)\n";
  auto list = [&](JointRole r, const char* label) {
    std::string names;
    int n = 0;
    for (std::int32_t j = 0; j < s.num_joints(); ++j)
      if (m.role[j] == r) names += (n++ ? ", " : "") + s.names[j];
    if (n) {
      std::snprintf(line, sizeof line, "%-10s %d: ", label, n);
      out += line + names + "\n";
    }
  };
  list(JointRole::root, "root");
  list(JointRole::helper, "helpers");
  list(JointRole::other, "unmapped");
  return out;
}

}  // namespace gatcore::character
