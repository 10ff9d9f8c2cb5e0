// `gat deform MODEL CHARACTER.glb MOTION.bvh -o OUT.glb [--point-cache OUT.pc2]`:
// a BVH motion retargeted onto the character, every frame linear blend
// skinned and corrected by a DenseGATs-family checkpoint, baked for playback
// as per-frame glTF morph targets (bake.hpp explains what a viewer shows)
// and / or a point cache. Each frame is the runtime's (runtime::Deformer,
// bound once): the tool's numbers and timings are an engine's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"
#include "gatcore/runtime.hpp"
#include "progress.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace gat {

namespace {

struct DeformArgs {
  std::string model_path, in, motion_path, out, pc2, frames_spec, up = "y";
  long start_frame = 1;
  std::vector<std::string> aliases;
  bool verbose = false;
  CommonOptions common;
};

int run(const DeformArgs& a) {
  const std::string &model_path = a.model_path, &in = a.in, &motion_path = a.motion_path, &out = a.out,
                    &pc2 = a.pc2, &frames_spec = a.frames_spec;
  const bool quiet = a.common.quiet;
  BoneAliases aliases;
  for (const auto& al : a.aliases) add_alias(aliases, al);
  GATCORE_CHECK(!out.empty() || !pc2.empty(), "nothing to write: give -o OUT.glb and / or --point-cache OUT.pc2");
  if (!out.empty()) {
    GATCORE_CHECK(is_gltf_path(out), out, ": the output must be a .glb or .gltf file");
    GATCORE_CHECK(is_gltf_path(in), in, ": -o bakes into the character's glTF file; for other formats write only "
                  "--point-cache");
  }
  // Fail before minutes of work, not after.
  for (const std::string& o : {out, pc2}) {
    const std::filesystem::path dir = std::filesystem::path(o).parent_path();
    GATCORE_CHECK(o.empty() || dir.empty() || std::filesystem::is_directory(dir), o, ": the directory ", dir.string(),
                  " does not exist");
  }
  apply_threads(a.common);
  const Device dev = device_from_flag(a.common.device, "deform");
  Activity doing("deforming " + in + " with " + model_path);
  runtime::Deformer d = runtime::Deformer::load(model_path, dev);
  const Character ch = load_character(in);
  const Motion motion = load_motion(motion_path);
  runtime::BindOptions bo;
  bo.aliases = aliases;
  bo.name = in;
  d.bind(ch.mesh, ch.skeleton, bo);
  RetargetOptions ro;  // --alias names joints for the retarget too (JOINT=PART or a known joint name)
  ro.target_name = in;
  ro.source_aliases = ro.target_aliases = aliases;
  const Skeleton& skeleton = d.bound_skeleton();
  const Clip clip = retarget(motion, skeleton, mat4_identity(), ro);
  const long nf = static_cast<long>(clip.frames.size());
  GATCORE_CHECK(nf > 0, motion_path, ": no frames");
  long first = 0, last = nf;
  if (!frames_spec.empty()) {
    const auto colon = frames_spec.find(':');
    GATCORE_CHECK(colon != std::string::npos, "--frames expects A:B, got '", frames_spec, "'");
    const std::string a = frames_spec.substr(0, colon), b = frames_spec.substr(colon + 1);
    if (!a.empty()) first = parse_int("--frames (start)", a, 0, nf);
    if (!b.empty()) last = parse_int("--frames (end)", b, 0, nf);
    GATCORE_CHECK(first < last, "--frames ", frames_spec, ": empty range; ", motion_path, " has frames [0, ", nf, ")");
  }
  const int nearest = d.nearest_joints();
  const std::string joints =
      nearest > 0 ? std::to_string(ch.skeleton.num_joints()) + " joints, each vertex's " + std::to_string(nearest) +
                        " nearest: any skeleton"
                  : std::to_string(d.mapped_joints()) + " of " + std::to_string(ch.skeleton.num_joints()) +
                        " joints matched";
  std::printf("gat deform: %s (%s) on %s (%lld vertices, %s), %s frames %ld..%ld at %g fps, device %s\n",
              d.model_name().c_str(), model_path.c_str(), in.c_str(), static_cast<long long>(ch.mesh.num_vertices()),
              joints.c_str(), motion_path.c_str(), first, last - 1, double(clip.fps), device_label(dev).c_str());
  warn_absent_bones("gat deform", d.absent_bones_warning(),
                    "use a model trained with --joint-columns nearest:K (any skeleton)");
  BakedFrames baked;
  baked.fps = clip.fps;
  const std::size_t n3 = static_cast<std::size_t>(3 * d.num_vertices());
  std::vector<float> globals(static_cast<std::size_t>(16 * skeleton.num_joints())), lbs(n3);
  double sum_f = 0, sum_i = 0, sum_t = 0, sum_corr = 0, max_corr = 0;
  const auto t_all = std::chrono::steady_clock::now();
  Progress progress("deforming", last - first, "frames", quiet);
  for (long f = first; f < last; ++f) {
    progress.update(f - first);
    const std::vector<Mat4> g = global_transforms(skeleton, clip.frames[static_cast<std::size_t>(f)]);
    for (std::size_t j = 0; j < g.size(); ++j) std::copy(g[j].begin(), g[j].end(), globals.begin() + 16 * j);
    std::vector<float> corrected(n3);
    d.deform(globals, corrected, {}, lbs);
    const runtime::FrameTiming t = d.last_timing();
    double mean = 0;
    for (std::size_t v = 0; v < n3 / 3; ++v) {
      const double dx = corrected[3 * v] - lbs[3 * v], dy = corrected[3 * v + 1] - lbs[3 * v + 1],
                   dz = corrected[3 * v + 2] - lbs[3 * v + 2];
      const double c = std::sqrt(dx * dx + dy * dy + dz * dz);
      mean += c;
      max_corr = std::max(max_corr, c);
    }
    mean /= double(std::max<std::size_t>(1, n3 / 3));
    sum_corr += mean;
    sum_f += t.features_ms, sum_i += t.model_ms, sum_t += t.total_ms;
    if (a.verbose && !quiet)
      std::printf("frame %4ld  features %7.1f ms  inference %7.1f ms  total %7.1f ms  mean correction %.5f\n", f,
                  t.features_ms, t.model_ms, t.total_ms, mean);
    baked.positions.push_back(std::move(corrected));
  }
  progress.finish();
  const double n = double(last - first);
  // Both outputs are complete in memory before either file is written.
  std::vector<std::string> pc2_paths;
  std::vector<ObjectPointCache> caches;
  if (!pc2.empty()) {
    caches = object_point_caches(ch, baked, a.up == "z" ? UpAxis::z : UpAxis::y, static_cast<float>(a.start_frame));
    pc2_paths = write_object_point_caches(pc2, caches);
  }
  try {
    if (!out.empty()) save_gltf_morph_animation(in, ch, baked, out);
  } catch (...) {
    for (const auto& p : pc2_paths) std::remove(p.c_str());  // all outputs or none
    throw;
  }
  std::printf("%ld frames in %.2f s: per frame features %.1f ms, inference %.1f ms, total %.1f ms (%.1f fps); "
              "correction mean %.5f max %.5f (character units)\n",
              last - first, std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count(), sum_f / n,
              sum_i / n, sum_t / n, 1e3 * n / std::max(sum_t, 1e-9), sum_corr / n, max_corr);
  if (!out.empty()) std::printf("  morph targets + animation '%s' -> %s\n", baked.name.c_str(), out.c_str());
  for (std::size_t i = 0; i < pc2_paths.size(); ++i)
    std::printf("  point cache of object '%s' (%d points, %s up, from frame %ld) -> %s\n", caches[i].object.c_str(),
                caches[i].cache.num_points, a.up.c_str(), a.start_frame, pc2_paths[i].c_str());
  return 0;
}

}  // namespace

Runner setup_deform(CLI::App& gat) {
  auto a = std::make_shared<DeformArgs>();
  CLI::App& c = add_command(gat, "deform",
                            "a motion on a character with DenseGATs corrections, baked as morph targets / .pc2");
  set_details(c, "Retargets the BVH motion onto CHARACTER (CMU joint names -> humanoid names), and for every frame "
                "adds the correction a displacement checkpoint (densegats, densegats-noself, densegats-nodense, "
                "origat; trained with gat train --data) predicts to linear blend skinning.");
  c.add_option("MODEL", a->model_path, "a displacement checkpoint (.gcm)")->required();
  c.add_option("CHARACTER", a->in, "the character (.glb / .gltf; others with --point-cache only)")->required();
  c.add_option("MOTION", a->motion_path, "a motion: .bvh, .amc (or SKELETON.asf:MOTION.amc), or a clip of a character file (other.glb#CLIP)")->required();
  add_out(c, a->out,
          "CHARACTER (.glb/.gltf) with one morph target per frame and an animation 'deform' that steps through them "
          "(joints held at the bind pose; the file's own animations are kept and play the plain skinned mesh)");
  c.add_option("--point-cache", a->pc2,
               "OUT.pc2: the deformed vertices per frame as point caches, one per mesh object of the character "
               "(OUT.pc2 for a single mesh, else OUT_<object>.pc2), in the object's own coordinates (docs/getting-started.md: "
               "Blender, Maya, Houdini)");
  c.add_option("--up", a->up,
               "the point caches' up axis: y (the file's, glTF's and Maya's) or z (Blender's and 3ds Max's: "
               "Blender's Mesh Cache modifier then needs no axis settings)")
      ->check(one_of({"y", "z"}))->capture_default_str();
  c.add_option("--start-frame", a->start_frame, "the scene frame of the first cached frame (Blender starts at 1)")
      ->check(int_in(-1000000, 1000000))->capture_default_str();
  c.add_option("--frames", a->frames_spec, "A:B: motion frames A .. B-1 (default all; A: and :B allowed)");
  add_repeatable(c, "--alias", a->aliases, "JOINT=BONE: treat the character's joint JOINT as the model's bone BONE");
  add_device(c, a->common);
  add_threads(c, a->common);
  c.add_flag("-v,--verbose", a->verbose, "a timing line per frame");
  add_quiet(c, a->common);
  return [a] { return run(*a); };
}

}  // namespace gat
