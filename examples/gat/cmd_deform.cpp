// `gat deform MODEL CHARACTER.glb MOTION.bvh -o OUT.glb [--point-cache OUT.pc2]`:
// a BVH motion retargeted onto the character, every frame linear blend
// skinned and corrected by a DenseGATs-family checkpoint, baked for playback
// as per-frame glTF morph targets (bake.hpp explains what a viewer shows)
// and / or a point cache.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <omp.h>

#include "cli_util.hpp"
#include "commands.hpp"
#include "gatcore/character/inference/corrective.hpp"
#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace gat {

namespace {

void usage(std::FILE* f) {
  std::fprintf(f,
               "usage: gat deform MODEL CHARACTER MOTION.bvh [-o OUT.glb] [--point-cache OUT.pc2] [--frames A:B]\n"
               "                  [--device cpu|vulkan|auto] [--alias JOINT=BONE ...] [--threads T] [--quiet]\n"
               "  Retargets the BVH motion onto CHARACTER (CMU joint names -> humanoid names), and for every\n"
               "  frame adds the correction a displacement checkpoint (densegats, densegats-noself,\n"
               "  densegats-nodense, origat; trained with gat train --data) predicts to linear blend skinning.\n"
               "  -o OUT.glb/.gltf    CHARACTER (.glb/.gltf) with one morph target per frame and an animation\n"
               "                      'deform' that steps through them (joints held at the bind pose; the\n"
               "                      file's own animations are kept and play the plain skinned mesh)\n"
               "  --point-cache F     the deformed file vertices per frame as a .pc2 point cache (world frame)\n"
               "  --frames A:B        motion frames A .. B-1 (default all; A: and :B allowed)\n"
               "  --device D          where the model runs (cpu default; see gat train --help)\n"
               "  --alias JOINT=BONE  treat the character's joint JOINT as the model's bone BONE (repeatable)\n"
               "  --quiet             no per-frame timing lines, only the summary\n");
}

}  // namespace

int cmd_deform(int argc, char** argv) {
  std::string model_path, in, motion_path, out, pc2, device = "cpu", frames_spec;
  long threads = 0;
  bool quiet = false;
  BoneAliases aliases;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw InvalidArgument(a + " expects a value");
      return argv[++i];
    };
    if (a == "-h" || a == "--help") {
      usage(stdout);
      return 0;
    } else if (a == "-o") {
      out = value();
    } else if (a == "--point-cache") {
      pc2 = value();
    } else if (a == "--frames") {
      frames_spec = value();
    } else if (a == "--device") {
      device = value();
    } else if (a == "--alias") {
      add_alias(aliases, value());
    } else if (a == "--threads") {
      threads = parse_int(a, value(), 1, 1024);
    } else if (a == "--quiet") {
      quiet = true;
    } else if (!a.empty() && a[0] != '-' && model_path.empty()) {
      model_path = a;
    } else if (!a.empty() && a[0] != '-' && in.empty()) {
      in = a;
    } else if (!a.empty() && a[0] != '-' && motion_path.empty()) {
      motion_path = a;
    } else {
      throw InvalidArgument("unknown or extra argument '" + a + "'");
    }
  }
  if (model_path.empty() || in.empty() || motion_path.empty() || (out.empty() && pc2.empty())) {
    usage(stderr);
    return 2;
  }
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
  if (threads > 0) omp_set_num_threads(int(threads));
  const Device dev = device_from_flag(device, "deform");
  models::LoadedModel lm = models::load_checkpoint(model_path);
  const std::vector<std::string> bones = character_model_bones(lm, model_path, models::Task::displacement);
  const Character ch = load_character(in);
  const Motion motion = load_bvh(motion_path);
  const CorrectiveDeformer d =
      make_corrective_deformer(ch, bones, aliases, checkpoint_distortion_scales(lm.file, model_path));
  RetargetOptions ro;  // --alias names joints for the retarget too (JOINT=PART or a known joint name)
  ro.target_name = in;
  ro.source_aliases = ro.target_aliases = aliases;
  const Clip clip = retarget(motion, d.prepared.character.skeleton, mat4_identity(), ro);
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
  lm.model->to(dev);
  lm.model->fold_batch_norm();
  std::printf("gat deform: %s (%s) on %s (%lld vertices, %d of %d joints matched), %s frames %ld..%ld at %g fps, "
              "device %s\n",
              lm.model->config().name.c_str(), model_path.c_str(), in.c_str(),
              static_cast<long long>(ch.mesh.num_vertices()), d.mapping.num_mapped(), ch.skeleton.num_joints(),
              motion_path.c_str(), first, last - 1, double(clip.fps), device_label(dev).c_str());
  BakedFrames baked;
  baked.fps = clip.fps;
  double sum_f = 0, sum_i = 0, sum_t = 0, sum_corr = 0, max_corr = 0;
  const auto t_all = std::chrono::steady_clock::now();
  for (long f = first; f < last; ++f) {
    const auto t0 = std::chrono::steady_clock::now();
    CorrectedFrame cf = deform_frame(d, *lm.model, lm.norm, clip.frames[static_cast<std::size_t>(f)]);
    const double total = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    double mean = 0;
    for (std::size_t v = 0; v < cf.lbs.size() / 3; ++v) {
      const double dx = cf.corrected[3 * v] - cf.lbs[3 * v], dy = cf.corrected[3 * v + 1] - cf.lbs[3 * v + 1],
                   dz = cf.corrected[3 * v + 2] - cf.lbs[3 * v + 2];
      const double c = std::sqrt(dx * dx + dy * dy + dz * dz);
      mean += c;
      max_corr = std::max(max_corr, c);
    }
    mean /= double(std::max<std::size_t>(1, cf.lbs.size() / 3));
    sum_corr += mean;
    sum_f += cf.ms_features, sum_i += cf.ms_inference, sum_t += total;
    if (!quiet)
      std::printf("frame %4ld  features %7.1f ms  inference %7.1f ms  total %7.1f ms  mean correction %.5f\n", f,
                  cf.ms_features, cf.ms_inference, total, mean);
    baked.positions.push_back(std::move(cf.corrected));
  }
  const double n = double(last - first);
  // Both outputs are complete in memory before either file is written.
  bool pc2_written = false;
  if (!pc2.empty()) {
    PointCache pc;
    pc.num_points = static_cast<std::int32_t>(ch.num_file_vertices());
    pc.start_frame = static_cast<float>(first);
    pc.sample_rate = 1.0f;
    for (const auto& p : baked.positions) pc.samples.push_back(file_vertex_positions(ch, p));
    write_point_cache(pc2, pc);
    pc2_written = true;
  }
  try {
    if (!out.empty()) save_gltf_morph_animation(in, ch, baked, out);
  } catch (...) {
    if (pc2_written) std::remove(pc2.c_str());  // all outputs or none
    throw;
  }
  std::printf("%ld frames in %.2f s: per frame features %.1f ms, inference %.1f ms, total %.1f ms (%.1f fps); "
              "correction mean %.5f max %.5f (character units)\n",
              last - first, std::chrono::duration<double>(std::chrono::steady_clock::now() - t_all).count(), sum_f / n,
              sum_i / n, sum_t / n, 1e3 * n / std::max(sum_t, 1e-9), sum_corr / n, max_corr);
  if (!out.empty()) std::printf("  morph targets + animation '%s' -> %s\n", baked.name.c_str(), out.c_str());
  if (!pc2.empty()) std::printf("  point cache (%lld points) -> %s\n", static_cast<long long>(ch.num_file_vertices()), pc2.c_str());
  return 0;
}

}  // namespace gat
