// Dispatching a user's motion spec to the reader of its file type.
#include "gatcore/character/io/motion_source.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "gatcore/character/io/asf.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/rig_convention.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string ext_of(const std::string& path) { return lower(fs::path(path).extension().string()); }

// The ASF an AMC file goes with, or "" (with the places looked in).
std::string find_asf(const std::string& amc, std::string& tried) {
  const fs::path p(amc);
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  std::vector<fs::path> candidates = {p.parent_path() / (p.stem().string() + ".asf"),
                                      p.parent_path() / (p.stem().string() + ".ASF")};
  const std::string stem = p.stem().string();
  if (const std::size_t u = stem.find('_'); u != std::string::npos && u > 0) {  // CMU: 02_01.amc -> 02.asf
    candidates.push_back(p.parent_path() / (stem.substr(0, u) + ".asf"));
    candidates.push_back(p.parent_path() / (stem.substr(0, u) + ".ASF"));
  }
  for (const fs::path& c : candidates) {
    tried += (tried.empty() ? "" : ", ") + c.string();
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) return c.string();
  }
  std::vector<fs::path> found;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (ext_of(it->path().string()) == ".asf" && it->is_regular_file(ec)) found.push_back(it->path());
  tried += ", the only .asf in " + dir.string();
  return found.size() == 1 ? found[0].string() : "";
}

Motion clip_of_character(const std::string& spec, const MotionLoadOptions& opt) {
  std::string path = spec, want;
  std::error_code ec;
  if (const std::size_t h = spec.rfind('#'); h != std::string::npos && !fs::exists(spec, ec)) {
    path = spec.substr(0, h);
    want = spec.substr(h + 1);
    GATCORE_CHECK(!want.empty(), spec, ": nothing after '#' (give a clip name or index, or drop the '#')");
  }
  ImportOptions io;
  io.clip_fps = opt.clip_fps;
  io.allow_no_skin = true;  // a glTF animation exported without its mesh is a motion all the same
  Character ch;
  try {
    ch = load_character(path, io);
  } catch (const InvalidArgument& e) {
    // The importers read the skeleton from the skins: an animation exported
    // without its mesh has none.
    if (std::string(e.what()).find("no skin") == std::string::npos) throw;
    throw InvalidArgument(detail::cat(e.what(), " (a motion needs an animation: of a skinned character, or of "
                                                "its skeleton's nodes; export the animation with its character mesh)"));
  }
  auto names = [&] {
    std::string n;
    for (std::size_t i = 0; i < ch.clips.size(); ++i)
      n += (i ? ", " : "") + std::to_string(i) + " '" + ch.clips[i].name + "'";
    return n;
  };
  GATCORE_CHECK(!ch.clips.empty(), path, ": the file has no animation to use as a motion (", ch.skeleton.num_joints(),
                " joints, no clips)");
  std::size_t pick = 0;
  if (!want.empty()) {
    pick = ch.clips.size();
    for (std::size_t i = 0; i < ch.clips.size() && pick == ch.clips.size(); ++i)
      if (ch.clips[i].name == want) pick = i;
    if (pick == ch.clips.size() && std::all_of(want.begin(), want.end(), ::isdigit) && want.size() < 9) {
      const std::size_t i = std::stoul(want);
      if (i < ch.clips.size()) pick = i;
    }
    GATCORE_CHECK(pick < ch.clips.size(), path, ": no clip '", want, "'; the file has ", ch.clips.size(),
                  ch.clips.size() == 1 ? " clip: " : " clips: ", names());
  }
  GATCORE_CHECK(!ch.clips[pick].frames.empty(), path, ": clip '", ch.clips[pick].name, "' has no frames");
  Motion m;
  m.name = spec;
  m.skeleton = std::move(ch.skeleton);
  m.clip = std::move(ch.clips[pick]);
  return m;
}

}  // namespace

Motion load_motion(const std::string& spec, const MotionLoadOptions& opt) {
  GATCORE_CHECK(!spec.empty(), "an empty motion path");
  const std::string l = lower(spec);
  if (const std::size_t c = l.find(".asf:"); c != std::string::npos) {
    const std::string asf = spec.substr(0, c + 4), amc = spec.substr(c + 5);
    GATCORE_CHECK(!amc.empty(), spec, ": give the motion after the skeleton: SKELETON.asf:MOTION.amc");
    return load_asf_amc(asf, amc, opt.amc_fps, opt.warn);
  }
  const std::string ext = ext_of(spec.substr(0, spec.rfind('#') == std::string::npos ? spec.size() : spec.rfind('#')));
  if (ext == ".bvh") return load_bvh(spec, opt.warn);
  if (ext == ".amc") {
    std::string tried;
    const std::string asf = find_asf(spec, tried);
    GATCORE_CHECK(!asf.empty(), spec, ": no ASF skeleton found for it (looked for ", tried,
                  "); name it: SKELETON.asf:", spec);
    return load_asf_amc(asf, spec, opt.amc_fps, opt.warn);
  }
  GATCORE_CHECK(ext != ".asf", spec, ": an ASF file holds a skeleton, not a motion; give its motion as ", spec,
                ":MOTION.amc (or the .amc, with the .asf beside it)");
  GATCORE_CHECK(!ext.empty() && ext != ".json" && ext != ".pc2" && ext != ".gcm", spec,
                ": not a motion file (expected .bvh, .amc, SKELETON.asf:MOTION.amc, or a character file with an "
                "animation: .glb, .gltf, .fbx, .dae, optionally #CLIP)");
  return clip_of_character(spec, opt);
}

std::string describe_motion_rig(const Motion& motion, const BoneAliases& aliases) {
  const MotionRig r = map_motion_rig(motion.skeleton, aliases);
  return "read as    " + r.frame + "\n" + describe_rig(motion.skeleton, r.mapping);
}

}  // namespace gatcore::character
