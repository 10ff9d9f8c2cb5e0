// The runtime in an engine, minimally: load a corrective checkpoint, bind a
// glTF character once, then per frame hand the runtime the joints' global
// transforms and get the corrected vertices back; a per-frame timing summary
// at the end. In an engine, only the part marked "per frame" runs in the
// game loop, and the joint matrices come from the engine's animation system
// (here a BVH retargeted onto the character stands in for it).
//
//   runtime_deform_clip MODEL.gcm CHARACTER.glb MOTION.bvh [-o OUT.pc2] [--threads T] [--device cpu|auto]
//                       [--precision fp32|bf16]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "gatcore/character/io/bake.hpp"
#include "gatcore/character/features/features.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/runtime.hpp"

using namespace gatcore;
using namespace gatcore::character;

int main(int argc, char** argv) {
  // Options through CLI11 like the gat tool (header-only; a missing or bad
  // argument is named, --opt=value works).
  std::string model, character, motion, out, device_name = "cpu", precision_name = "fp32";
  int threads = 0;
  CLI::App app("The runtime in an engine, minimally: deform CHARACTER with MOTION through the runtime's per-frame "
               "call, print per-frame timings, optionally write a point cache.",
               "runtime_deform_clip");
  app.add_option("MODEL", model, "a corrective checkpoint (.gcm)")->required();
  app.add_option("CHARACTER", character, "the character (.glb / .gltf / anything gat info reads)")->required();
  app.add_option("MOTION", motion, "a BVH motion, retargeted onto the character")->required();
  app.add_option("-o,--out", out, "write the deformed frames as a point cache (.pc2)");
  app.add_option("--threads", threads, "OpenMP threads (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::Range(1, 1024));
  app.add_option("--device", device_name, "cpu, or auto (Vulkan when a device is found)")
      ->check(CLI::IsMember({"cpu", "auto"}))
      ->capture_default_str();
  app.add_option("--precision", precision_name,
                 "fp32, or bf16: the products in bfloat16 on CPUs with AVX512_BF16 (gatcore/precision.hpp)")
      ->check(CLI::IsMember({"fp32", "bf16"}))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);  // prints the help, or the error naming the argument
    return rc == 0 ? 0 : 2;      // usage errors: 2, as the gat tool
  }
  if (threads > 0) omp_set_num_threads(threads);
  const runtime::DeviceChoice device =
      device_name == "auto" ? runtime::DeviceChoice::automatic : runtime::DeviceChoice::cpu;
  try {
    // ---- load and bind: once per character ----
    runtime::Deformer deformer = runtime::Deformer::load(model, device, parse_precision(precision_name));
    const Character ch = load_character(character);
    deformer.bind(ch.mesh, ch.skeleton);
    std::printf("%s: %lld vertices, %d joints (%d matched to the model's bones); model %s, %lld parameters\n",
                character.c_str(), static_cast<long long>(deformer.num_vertices()), deformer.num_joints(),
                deformer.mapped_joints(), deformer.model_name().c_str(),
                static_cast<long long>(deformer.parameter_count()));
    // The engine's animation, stood in for by a retargeted BVH.
    const Clip clip = retarget(load_bvh(motion), ch.skeleton, compute_normalisation(ch).bind_to_world);

    std::vector<float> joint_globals(std::size_t(16 * deformer.num_joints()));
    std::vector<float> positions(std::size_t(3 * deformer.num_vertices()));
    std::vector<double> total_ms, features_ms, model_ms;
    PointCache cache;
    cache.num_points = std::int32_t(ch.num_file_vertices());
    for (const Pose& pose : clip.frames) {
      const std::vector<Mat4> g = global_transforms(ch.skeleton, pose);
      for (std::size_t j = 0; j < g.size(); ++j) std::copy(g[j].begin(), g[j].end(), joint_globals.begin() + 16 * j);
      // ---- per frame ----
      const auto t0 = std::chrono::steady_clock::now();
      deformer.deform(joint_globals, positions);
      total_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      features_ms.push_back(deformer.last_timing().features_ms);
      model_ms.push_back(deformer.last_timing().model_ms);
      // ---- end of per frame ----
      if (!out.empty()) cache.samples.push_back(file_vertex_positions(ch, positions));
    }
    if (!out.empty()) write_point_cache(out, cache);
    auto mean = [](const std::vector<double>& v) {
      double s = 0;
      for (double x : v) s += x;
      return v.empty() ? 0.0 : s / double(v.size());
    };
    std::vector<double> sorted = total_ms;
    std::sort(sorted.begin(), sorted.end());
    const auto pct = [&](double p) { return sorted.empty() ? 0.0 : sorted[std::size_t(p * double(sorted.size() - 1))]; };
    std::printf("%zu frames, %d threads: per frame mean %.2f ms (features %.2f + model %.2f), median %.2f, p95 %.2f, "
                "max %.2f ms (%.0f fps)\n",
                total_ms.size(), omp_get_max_threads(), mean(total_ms), mean(features_ms), mean(model_ms), pct(0.5),
                pct(0.95), sorted.empty() ? 0.0 : sorted.back(), 1e3 / std::max(mean(total_ms), 1e-9));
    if (!out.empty()) std::printf("point cache -> %s\n", out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "runtime_deform_clip: %s\n", e.what());
    return 1;
  }
  return 0;
}
