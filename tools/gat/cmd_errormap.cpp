// `gat errormap CHARACTER -o out.png [--seed N] [--angle RAD] [--motion M.bvh --frame F]`:
// poses a character (a random pose, or a frame of a retargeted BVH motion),
// and renders where linear blend skinning departs from the reference
// deformer (Delta Mush on LBS) as a per-vertex error colour map.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/error.hpp"

using namespace gatcore::character;

namespace gat {

namespace {

struct ErrormapArgs {
  std::string in, out, motion;
  long seed = 1, frame = 0;
  float angle = 0.6f;
  std::vector<std::string> aliases;
};

int run_errormap(const ErrormapArgs& a) {
  const std::string &in = a.in, &out = a.out, &motion = a.motion;
  const long frame = a.frame;
  const float angle = a.angle;
  const unsigned seed = static_cast<unsigned>(a.seed);
  BoneAliases aliases;
  for (const auto& al : a.aliases) add_alias(aliases, al);
  const PreparedCharacter pc = prepare_character(load_character(in));
  Pose pose;
  if (!motion.empty()) {
    RetargetOptions ro;
    ro.target_name = in;
    ro.source_aliases = ro.target_aliases = aliases;
    const Clip clip = retarget(load_motion(motion), pc.character.skeleton, mat4_identity(), ro);
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

}  // namespace

Runner setup_errormap(CLI::App& gat) {
  auto a = std::make_shared<ErrormapArgs>();
  CLI::App& c = add_command(gat, "errormap",
                            "render where LBS departs from the reference deformer (Delta Mush) as a PNG");
  set_details(c, "Renders |Delta Mush - LBS| per vertex for a random pose (joint angles within +-RAD) or for frame F "
                "of a BVH motion retargeted through the rig conventions (gat info shows the body map), with a colour bar in "
                "character heights.");
  c.add_option("CHARACTER", a->in, "a character file (.glb / .gltf / .fbx / .dae)")->required();
  add_out(c, a->out, "the PNG to write")->required();
  add_seed(c, a->seed, "the random pose");
  c.add_option("--angle", a->angle, "random joint angles within +-RAD")->check(number_in(0, 3.2))->capture_default_str();
  c.add_option("--motion", a->motion, "pose from a motion (.bvh, .amc, SKELETON.asf:MOTION.amc, other.glb#CLIP) instead of a random pose");
  c.add_option("--frame", a->frame, "the motion's frame")->check(int_in(0, 100000000))->capture_default_str();
  add_repeatable(c, "--alias", a->aliases,
                 "JOINT=PART: names a joint the rig-convention map misses (gat info shows the body map), e.g. "
                 "Bone.012=thigh.l");
  return [a, &c] {
    GATCORE_CHECK(a->motion.empty() ? !c.count("--frame") : !c.count("--seed") && !c.count("--angle"),
                  a->motion.empty() ? "--frame needs --motion" : "--seed / --angle pick a random pose; not with --motion");
    return run_errormap(*a);
  };
}

}  // namespace gat
