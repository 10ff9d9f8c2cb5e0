// `gat errormap CHARACTER -o out.png [--seed N] [--angle RAD] [--motion M.bvh --frame F]`:
// poses a character (a random pose, or a frame of a retargeted BVH motion),
// and renders where linear blend skinning departs from the reference
// deformer (Delta Mush on LBS) as a per-vertex error colour map.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace gat {

int cmd_errormap(int argc, char** argv) {
  std::string in, out, motion;
  unsigned seed = 1;
  float angle = 0.6f;
  long frame = 0;
  BoneAliases aliases;
  auto usage = [](std::FILE* f) {
    std::fprintf(f,
                 "usage: gat errormap CHARACTER -o OUT.png [--seed N] [--angle RAD] [--motion M.bvh --frame F]\n"
                 "                     [--alias JOINT=PART ...]\n"
                 "  renders |Delta Mush - LBS| per vertex for a random pose (joint angles within +-RAD)\n"
                 "  or for frame F of a BVH motion retargeted through the rig conventions (gat info shows\n"
                 "  the body map; --alias names a joint the map misses, e.g. Bone.012=thigh.l)\n");
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw gatcore::InvalidArgument(a + " expects a value");
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      usage(stdout);
      return 0;
    } else if (a == "-o") {
      out = value();
    } else if (a == "--seed") {
      seed = static_cast<unsigned>(std::strtoul(value().c_str(), nullptr, 10));
    } else if (a == "--angle") {
      angle = std::strtof(value().c_str(), nullptr);
    } else if (a == "--motion") {
      motion = value();
    } else if (a == "--frame") {
      frame = std::strtol(value().c_str(), nullptr, 10);
    } else if (a == "--alias") {
      add_alias(aliases, value());
    } else if (in.empty() && a[0] != '-') {
      in = a;
    } else {
      throw gatcore::InvalidArgument("unknown argument '" + a + "'");
    }
  }
  if (in.empty() || out.empty()) {
    usage(stderr);
    return 2;
  }
  const PreparedCharacter pc = prepare_character(load_character(in));
  Pose pose;
  if (!motion.empty()) {
    RetargetOptions ro;
    ro.target_name = in;
    ro.source_aliases = ro.target_aliases = aliases;
    const Clip clip = retarget(load_bvh(motion), pc.character.skeleton, mat4_identity(), ro);
    GATCORE_CHECK(frame >= 0 && frame < static_cast<long>(clip.frames.size()), motion, ": --frame ", frame,
                  " outside [0, ", clip.frames.size(), ")");
    pose = clip.frames[static_cast<std::size_t>(frame)];
  } else {
    std::mt19937 rng(seed);
    pose = random_pose(pc.character.skeleton, pc.rest, uniform_limits(pc.character.skeleton, angle), rng);
  }
  const DenseGatsSample s = make_densegats_sample(pc, pose, 0, 0);
  std::vector<float> err(static_cast<std::size_t>(s.target.rows()));
  double mean = 0.0, mx = 0.0;
  for (std::size_t v = 0; v < err.size(); ++v) {
    const float* t = s.target.row(static_cast<std::int64_t>(v));
    err[v] = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    mean += err[v];
    mx = std::max<double>(mx, err[v]);
  }
  const std::vector<float> lbs = s.lbs.to_vector();
  write_png(out, render_error_map(lbs, pc.character.mesh.triangles, err));
  std::printf("%s: %zu vertices, |Delta Mush - LBS| mean %.5f max %.5f (character heights) -> %s\n", in.c_str(),
              err.size(), err.empty() ? 0.0 : mean / err.size(), mx, out.c_str());
  return 0;
}

}  // namespace gat
