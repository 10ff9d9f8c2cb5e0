// The joint names of the rig conventions users bring (from each tool's own
// documentation and default rigs): one table per convention, written with
// side placeholders and expanded to both sides once. Adding a convention is
// adding a table here; rig_convention.cpp picks the table that explains
// most joints of a skeleton.
#include <cctype>

#include "src/character/rig/rig_tables.hpp"

namespace gatcore::character::rig_detail {

namespace {

// Expands '<' (left/right), '{' (l/r) in keys and '<' (.l/.r) in parts.
struct Builder {
  RigTable t;
  explicit Builder(std::string name) { t.name = std::move(name); }

  static std::string side(const std::string& s, bool left, bool part) {
    std::string out;
    for (char c : s) {
      if (c == '<') out += part ? (left ? ".l" : ".r") : (left ? "left" : "right");
      else if (c == '{' && !part) out += left ? "l" : "r";
      else out.push_back(c);
    }
    return out;
  }
  Builder& add(const std::string& key, const std::string& part) {
    const bool sided = key.find_first_of("<{") != std::string::npos;
    t.entries.push_back({side(key, true, false), side(part, true, true)});
    if (sided) t.entries.push_back({side(key, false, false), side(part, false, true)});
    return *this;
  }
  // key prefix + each suffix -> part (fingers, spine segments).
  Builder& add_each(const std::string& prefix, std::initializer_list<const char*> suffixes, const std::string& part,
                    const std::string& after = "") {
    for (const char* s : suffixes) add(prefix + s + after, part);
    return *this;
  }
  Builder& sig(std::initializer_list<const char*> keys) {
    for (const char* k : keys) t.signature.emplace_back(k);
    return *this;
  }
};

// Mixamo, Maya HumanIK, MotionBuilder / CMU and Axis Neuron BVH share these:
// Hips, Spine.., Neck, Head, LeftShoulder, LeftArm, LeftForeArm, LeftHand,
// LeftUpLeg, LeftLeg, LeftFoot, LeftToeBase, LeftHandIndex1.. .
Builder& humanik_base(Builder& b) {
  b.add("hips", "pelvis").add("spine", "spine").add_each("spine", {"1", "2", "3", "4", "5", "6", "7", "8", "9"}, "spine");
  b.add("neck", "neck").add_each("neck", {"1", "2", "3"}, "neck").add("head", "head");
  b.add("<shoulder", "clavicle<").add("<arm", "upperarm<").add("<forearm", "forearm<").add("<hand", "hand<");
  b.add("<upleg", "thigh<").add("<leg", "shin<").add("<foot", "foot<").add("<toebase", "toe<");
  for (const char* f : {"thumb", "index", "middle", "ring", "pinky"})
    b.add_each(std::string("<hand") + f, {"1", "2", "3", "4"}, std::string(f) + "<");
  b.add("headtopend", "-").add("<toeend", "-").add("<footindex1", "-");
  return b;
}

std::vector<RigTable> build() {
  std::vector<RigTable> all;
  {  // Quaternius modular characters (and the older packs, whose feet hang off the root as IK bones).
    Builder b("Quaternius");
    b.add("root", "^").add("hips", "pelvis").add("abdomen", "spine").add("torso", "spine").add("chest", "spine");
    b.add("neck", "neck").add("head", "head").add("shoulder{", "clavicle<").add("upperarm{", "upperarm<");
    b.add("lowerarm{", "forearm<").add("hand{", "hand<").add("fist{", "hand<").add("upperleg{", "thigh<");
    b.add("lowerleg{", "shin<").add("foot{", "foot<").add("toes{", "toe<");
    for (const char* f : {"thumb", "index", "middle", "ring", "pinky"})
      b.add_each(f, {"1", "2", "3", "4"}, std::string(f) + "<", "{");
    b.add("pt{", "-").add("poletarget{", "-").add("weapon", "-");
    b.sig({"abdomen", "torso", "upperlegl", "shoulderl"});
    all.push_back(b.t);
  }
  {
    Builder b("Mixamo");
    humanik_base(b).sig({"~mixamorig", "headtopend", "lefttoeend", "lefthandindex4", "lefthandthumb4"});
    all.push_back(b.t);
  }
  {
    Builder b("Maya HumanIK");
    humanik_base(b).add("reference", "^").add("<armroll", "-").add("<forearmroll", "-").add("<uplegroll", "-");
    b.add("<legroll", "-").add("<shoulderextra", "-");
    for (const char* f : {"thumb", "index", "middle", "ring", "pinky"}) b.add(std::string("<inhand") + f, "-");
    b.sig({"reference", "leftarmroll", "leftforearmroll", "leftuplegroll", "leftlegroll", "leftshoulderextra"});
    all.push_back(b.t);
  }
  {  // CMU's BVH (the cgspeed conversion) and MotionBuilder-style BVH.
    Builder b("CMU / MotionBuilder BVH");
    humanik_base(b).add("lowerback", "spine").add("{hipjoint", "-").add("<fingerbase", "-").add("{thumb", "thumb<");
    b.sig({"lowerback", "lhipjoint", "rhipjoint", "lthumb", "leftfingerbase"});
    all.push_back(b.t);
  }
  {  // Noitom Axis Neuron BVH: HumanIK names plus LeftInHandIndex.. metacarpals.
    Builder b("Axis Neuron BVH");
    humanik_base(b);
    for (const char* f : {"thumb", "index", "middle", "ring", "pinky"}) b.add(std::string("<inhand") + f, "-");
    b.sig({"leftinhandindex", "leftinhandmiddle", "rightinhandring"});
    all.push_back(b.t);
  }
  for (int ue = 4; ue <= 5; ++ue) {  // Epic's mannequins: UE4 (spine_01..03) and UE5 Manny/Quinn (spine_01..05, neck_02, metacarpals).
    Builder b(ue == 4 ? "Unreal mannequin (UE4)" : "Unreal mannequin (UE5)");
    b.add("root", "^").add("pelvis", "pelvis").add_each("spine0", {"1", "2", "3"}, "spine").add("neck01", "neck");
    b.add("head", "head").add("clavicle{", "clavicle<").add("upperarm{", "upperarm<").add("lowerarm{", "forearm<");
    b.add("hand{", "hand<").add("thigh{", "thigh<").add("calf{", "shin<").add("foot{", "foot<").add("ball{", "toe<");
    for (const char* f : {"thumb", "index", "middle", "ring", "pinky"})
      b.add_each(std::string(f) + "0", {"1", "2", "3"}, std::string(f) + "<", "{");
    for (const char* t : {"upperarmtwist0", "lowerarmtwist0", "thightwist0", "calftwist0"})
      b.add_each(t, {"1", "2"}, "-", "{");
    b.add("ikfootroot", "-").add("ikfoot{", "-").add("ikhandroot", "-").add("ikhandgun", "-").add("ikhand{", "-");
    if (ue == 5) {
      b.add_each("spine0", {"4", "5"}, "spine").add("neck02", "neck");
      for (const char* f : {"index", "middle", "ring", "pinky"}) b.add(std::string(f) + "metacarpal{", "-");
      b.sig({"spine04", "spine05", "neck02", "indexmetacarpall"});
    } else {
      b.sig({"calfl", "balll", "spine03"});
    }
    all.push_back(b.t);
  }
  // Blender: Rigify's generated deform bones (DEF-), the same rig's ORG-
  // copies when only those were exported, and the metarig itself. The spine
  // is one chain: spine (hips), .001-.003 (spine, chest), .004-.005 (neck), .006 (head).
  for (const char* prefix : {"def", "org", ""}) {
    const std::string p = prefix;
    Builder b(p == "def" ? "Blender Rigify (DEF-)" : p == "org" ? "Blender Rigify (ORG-)" : "Blender metarig");
    b.add(p + "spine", "pelvis").add_each(p + "spine00", {"1", "2", "3"}, "spine");
    b.add_each(p + "spine00", {"4", "5"}, "neck").add(p + "spine006", "head");
    b.add(p + "shoulder{", "clavicle<").add(p + "upperarm{", "upperarm<").add(p + "forearm{", "forearm<");
    b.add(p + "hand{", "hand<").add(p + "thigh{", "thigh<").add(p + "shin{", "shin<").add(p + "foot{", "foot<");
    b.add(p + "toe{", "toe<").add(p + "heel02{", "-").add(p + "breast{", "-").add(p + "pelvis{", "-");
    for (const char* seg : {"upperarm{", "forearm{", "thigh{", "shin{"}) b.add(p + seg + "001", "-");  // twist segments
    b.add_each(p + "thumb0", {"1", "2", "3"}, "thumb<", "{");
    for (const char* f : {"index", "middle", "ring", "pinky"})
      b.add_each(p + "f" + f + "0", {"1", "2", "3"}, std::string(f) + "<", "{");
    b.add_each(p + "palm0", {"1", "2", "3", "4"}, "-", "{");
    if (p == "def") {  // a full Rigify export: its ORG- bones follow the DEF- ones
      for (const char* seg : {"spine", "thigh{", "shin{", "foot{", "toe{", "upperarm{", "forearm{", "hand{", "shoulder{"})
        b.add(std::string("org") + seg, "-");
      b.sig({"defthighl", "defspine001", "defupperarml"});
    } else if (p == "org") {
      b.sig({"orgthighl", "orgspine001", "orgupperarml"});
    } else {
      b.sig({"spine001", "spine004", "heel02l", "upperarml"});
    }
    all.push_back(b.t);
  }
  {  // 3ds Max Biped: Bip01 (or Bip001) [L|R] Part; thighs hang off the spine, clavicles off the neck.
    Builder b("3ds Max Biped");
    b.add("bip01", "^").add("bip01pelvis", "pelvis").add("bip01spine", "spine");
    b.add_each("bip01spine", {"1", "2", "3"}, "spine").add("bip01neck", "neck").add("bip01neck1", "neck");
    b.add("bip01head", "head").add("bip01{clavicle", "clavicle<").add("bip01{upperarm", "upperarm<");
    b.add("bip01{forearm", "forearm<").add("bip01{hand", "hand<").add("bip01{thigh", "thigh<");
    b.add("bip01{calf", "shin<").add("bip01{foot", "foot<").add("bip01{toe0", "toe<").add("bip01footsteps", "-");
    const char* fingers[] = {"thumb<", "index<", "middle<", "ring<", "pinky<"};
    for (int f = 0; f < 5; ++f)
      for (const char* seg : {"", "1", "2"})
        b.add("bip01{finger" + std::to_string(f) + seg, fingers[f]);
    b.sig({"bip01pelvis", "bip01lthigh", "bip01lcalf"});
    all.push_back(b.t);
  }
  {  // Daz / Poser BVH and Genesis 1-2: hip, abdomen, chest, lCollar, lShldr, lForeArm, lThigh, lShin.
    Builder b("Daz / Poser");
    b.add("hip", "pelvis").add("abdomen", "spine").add("abdomen2", "spine").add("chest", "spine");
    b.add("neck", "neck").add("head", "head").add("{collar", "clavicle<").add("{shldr", "upperarm<");
    b.add("{forearm", "forearm<").add("{hand", "hand<").add("{buttock", "-").add("{thigh", "thigh<");
    b.add("{shin", "shin<").add("{foot", "foot<").add("{toe", "toe<");
    b.sig({"lcollar", "lshldr", "lbuttock", "abdomen2"});
    all.push_back(b.t);
  }
  {  // Daz Genesis 3 / 8: bend + twist segments, lower/upper spine parts.
    Builder b("Daz Genesis");
    b.add("hip", "pelvis").add("pelvis", "-").add("abdomenlower", "spine").add("abdomenupper", "spine");
    b.add("chestlower", "spine").add("chestupper", "spine").add("necklower", "neck").add("neckupper", "neck");
    b.add("head", "head").add("{collar", "clavicle<").add("{shldrbend", "upperarm<").add("{shldrtwist", "-");
    b.add("{forearmbend", "forearm<").add("{forearmtwist", "-").add("{hand", "hand<").add("{thighbend", "thigh<");
    b.add("{thightwist", "-").add("{shin", "shin<").add("{foot", "foot<").add("{metatarsals", "-").add("{toe", "toe<");
    b.add("{pectoral", "-").add_each("{carpal", {"1", "2", "3", "4"}, "-");
    b.add_each("{thumb", {"1", "2", "3"}, "thumb<").add_each("{index", {"1", "2", "3"}, "index<");
    b.add_each("{mid", {"1", "2", "3"}, "middle<").add_each("{ring", {"1", "2", "3"}, "ring<");
    b.add_each("{pinky", {"1", "2", "3"}, "pinky<");
    b.sig({"lthighbend", "lshldrbend", "abdomenlower", "chestupper"});
    all.push_back(b.t);
  }
  {  // KayKit characters: lower-case Blender names with IK and control helpers.
    Builder b("KayKit");
    b.add("root", "^").add("hips", "pelvis").add("spine", "spine").add("chest", "spine").add("neck", "neck");
    b.add("head", "head").add("shoulder{", "clavicle<").add("upperarm{", "upperarm<").add("lowerarm{", "forearm<");
    b.add("wrist{", "hand<").add("hand{", "-").add("handslot{", "-").add("upperleg{", "thigh<");
    b.add("lowerleg{", "shin<").add("foot{", "foot<").add("toes{", "toe<");
    for (const char* h : {"kneeik{", "elbowik{", "handik{", "heelik{", "ikfoot{", "iktoe{", "controlfootroll{",
                          "controlheelroll{", "controltoeroll{"})
      b.add(h, "-");
    b.sig({"wristl", "toesl", "handslotl", "kneeikl", "controlfootrolll"});
    all.push_back(b.t);
  }
  {  // VRM humanoid bones (0.x and 1.0).
    Builder b("VRM humanoid");
    b.add("hips", "pelvis").add("spine", "spine").add("chest", "spine").add("upperchest", "spine");
    b.add("neck", "neck").add("head", "head").add("<shoulder", "clavicle<").add("<upperarm", "upperarm<");
    b.add("<lowerarm", "forearm<").add("<hand", "hand<").add("<upperleg", "thigh<").add("<lowerleg", "shin<");
    b.add("<foot", "foot<").add("<toes", "toe<").add("<eye", "-").add("jaw", "-");
    b.add_each("<thumb", {"metacarpal", "proximal", "intermediate", "distal"}, "thumb<");
    for (const char* f : {"index", "middle", "ring", "little"})
      b.add_each(std::string("<") + f, {"proximal", "intermediate", "distal"},
                 std::string(f) == "little" ? "pinky<" : std::string(f) + "<");
    b.sig({"leftupperleg", "leftlowerarm", "upperchest", "leftindexproximal"});
    all.push_back(b.t);
  }
  {  // Joint-named rigs: a name says which joint a bone starts at (Biovision BVH, many studios' and
     // OptiTrack's BVH exports, the CMU captures' 3ds Max conversion): LeftShoulder is the upper arm,
     // LeftHip the thigh, LeftAnkle the foot. Sides as Left / L / l prefixes or suffixes.
    Builder b("Joint-named (Biovision / CMU 3ds Max BVH)");
    b.add("hips", "pelvis").add("pelvis", "pelvis").add("lowerback", "spine").add("upperback", "spine");
    b.add("abdomen", "spine").add("chest", "spine").add_each("chest", {"1", "2", "3", "4"}, "spine");
    b.add("spine", "spine").add_each("spine", {"1", "2", "3"}, "spine").add("neck", "neck");
    b.add_each("neck", {"1", "2"}, "neck").add("head", "head").add("headend", "-").add("{hipjoint", "-");
    for (const char* side : {"<", "{", "@{"}) {
      const std::string sd = side;
      auto key = [&](const char* base) { return sd == "@{" ? std::string(base) + "{" : sd + base; };
      b.add(key("collar"), "clavicle<").add(key("clavicle"), "clavicle<").add(key("shoulder"), "upperarm<");
      b.add(key("elbow"), "forearm<").add(key("wrist"), "hand<").add(key("hip"), "thigh<");
      b.add(key("knee"), "shin<").add(key("ankle"), "foot<").add(key("toe"), "toe<").add(key("toes"), "toe<");
    }
    b.sig({"leftcollar", "leftelbow", "leftwrist", "leftknee", "leftankle", "lefthip", "lelbow", "lknee"});
    all.push_back(b.t);
  }
  {  // The CMU database's own ASF bone names (and BVH files that keep them): a joint per bone, at its start.
    Builder b("CMU ASF");
    b.add("root", "pelvis").add("{hipjoint", "-").add("{femur", "thigh<").add("{tibia", "shin<").add("{foot", "foot<");
    b.add("{toes", "toe<").add("lowerback", "spine").add("upperback", "spine").add("thorax", "spine");
    b.add("lowerneck", "neck").add("upperneck", "neck").add("head", "head").add("{clavicle", "clavicle<");
    b.add("{humerus", "upperarm<").add("{radius", "forearm<").add("{wrist", "hand<").add("{hand", "-");
    b.add("{fingers", "-").add("{thumb", "-");
    b.sig({"lfemur", "ltibia", "lhumerus", "lradius", "thorax", "upperneck"});
    all.push_back(b.t);
  }
  {  // OptiTrack Motive / Arena skeletons: Hip, Ab, Chest, LShoulder, LUArm, LFArm, LThigh, LShin, LToe.
    Builder b("OptiTrack / Arena");
    b.add("hip", "pelvis").add("ab", "spine").add("chest", "spine").add("neck", "neck").add("head", "head");
    b.add("{shoulder", "clavicle<").add("{uarm", "upperarm<").add("{farm", "forearm<").add("{hand", "hand<");
    b.add("{thigh", "thigh<").add("{shin", "shin<").add("{foot", "foot<").add("{toe", "toe<");
    b.sig({"luarm", "lfarm", "ab"});
    all.push_back(b.t);
  }
  {  // Generic bone names seen in BVH from many tools (Biovision's LeftUpArm / LeftLowArm, Rokoko's
     // LeftThigh / LeftShin, ...): last, so it names a convention only when it explains strictly most
     // joints; its names also fill in what another table lacks.
    Builder b("Generic bone names");
    b.add("pelvis", "pelvis").add("hips", "pelvis").add("hip", "pelvis").add("root", "^");
    for (const char* side : {"<", "{", "@{", "@<"}) {
      const std::string sd = side;
      auto key = [&](const char* base) {
        return sd == "@{" ? std::string(base) + "{" : sd == "@<" ? std::string(base) + "<" : sd + base;
      };
      b.add(key("clavicle"), "clavicle<").add(key("collar"), "clavicle<").add(key("collarbone"), "clavicle<");
      for (const char* n : {"uparm", "upperarm", "arm"}) b.add(key(n), "upperarm<");
      for (const char* n : {"lowarm", "lowerarm", "forearm"}) b.add(key(n), "forearm<");
      b.add(key("hand"), "hand<");
      for (const char* n : {"upleg", "upperleg", "thigh", "femur"}) b.add(key(n), "thigh<");
      for (const char* n : {"lowleg", "lowerleg", "shin", "calf", "leg", "tibia"}) b.add(key(n), "shin<");
      b.add(key("foot"), "foot<").add(key("toe"), "toe<").add(key("toes"), "toe<").add(key("toebase"), "toe<");
      b.add(key("ball"), "toe<");
    }
    all.push_back(b.t);
  }
  return all;
}

}  // namespace

const std::vector<RigTable>& rig_tables() {
  static const std::vector<RigTable> tables = build();
  return tables;
}

std::string rig_key(const std::string& name) {
  std::string s = name;
  const std::size_t cut = s.find_last_of(":|");
  if (cut != std::string::npos && cut + 1 < s.size()) s = s.substr(cut + 1);
  std::string k;
  for (char c : s)
    if (std::isalnum(static_cast<unsigned char>(c))) k.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  // 3ds Max numbers its Biped "Bip01" or "Bip001".
  if (k.rfind("bip0", 0) == 0) {
    std::size_t e = 3;
    while (e < k.size() && k[e] == '0') ++e;
    if (e < k.size() && k[e] == '1') k = "bip01" + k.substr(e + 1);
  }
  return k;
}

bool is_chain_part(const std::string& part) {
  const std::string base = part.size() > 2 && part[part.size() - 2] == '.' ? part.substr(0, part.size() - 2) : part;
  for (const char* c : {"spine", "neck", "thumb", "index", "middle", "ring", "pinky"})
    if (base == c) return true;
  return false;
}

}  // namespace gatcore::character::rig_detail
