// reference_cost: what the reference deformers and a trained DenseGATs cost
// per frame on one character (docs/RESULTS.md, "ARAP reference deformer").
//
//   reference_cost CHARACTER.glb MOTION.bvh [FRAMES] [MODEL.gcm]
//
// Over the first FRAMES (default 20) frames of MOTION retargeted onto the
// character it times, per frame: LBS, Delta Mush on LBS (the default
// reference, 10 x 0.5), ARAP on LBS (arap.hpp defaults: 10 iterations,
// handles at dominant weight >= 0.95) and, with MODEL, DenseGATs' corrective
// frame (features + inference, corrective.hpp). It prints the median CPU
// milliseconds of each (process CPU time, so a loaded machine does not
// inflate it; OMP_NUM_THREADS=1 for one core), the one-off ARAP binding (factorisation) time, the
// mean distance of each reference to LBS (the size of what a network learns)
// and ARAP's energy before and after its iterations.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "gatcore/character/deform/arap.hpp"
#include "gatcore/character/inference/character_model.hpp"
#include "gatcore/character/inference/corrective.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/rig/motion.hpp"
#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

// Process CPU time, not wall time: on a shared, loaded machine wall time
// measures the other processes too. Run with OMP_NUM_THREADS=1 for the cost
// of one core (with more threads it is the sum over the threads).
struct Clock {
  using time_point = std::clock_t;
  static time_point now() { return std::clock(); }
};
double ms_since(Clock::time_point t) { return 1000.0 * double(std::clock() - t) / CLOCKS_PER_SEC; }

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double mean_distance(const std::vector<float>& a, const std::vector<float>& b) {
  double s = 0;
  for (std::size_t v = 0; v < a.size() / 3; ++v) {
    double d = 0;
    for (int c = 0; c < 3; ++c) d += (double(a[3 * v + c]) - b[3 * v + c]) * (double(a[3 * v + c]) - b[3 * v + c]);
    s += std::sqrt(d);
  }
  return s / double(std::max<std::size_t>(1, a.size() / 3));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: reference_cost CHARACTER.glb MOTION.bvh [FRAMES] [MODEL.gcm]\n");
    return 2;
  }
  try {
    const int frames = argc > 3 ? std::atoi(argv[3]) : 20;
    if (frames < 1) throw InvalidArgument(std::string("FRAMES must be >= 1, got '") + argv[3] + "'");
    const Character ch = load_character(argv[1]);
    const PreparedCharacter pc = prepare_character(ch, DeltaMushParams{}, {});
    const Character& w = pc.character;
    const Clip clip = retarget(load_bvh(argv[2]), w.skeleton, mat4_identity());
    const int F = std::min<int>(frames, int(clip.frames.size()));
    auto t = Clock::now();
    const ArapBinding arap = arap_bind(w.mesh);
    const double bind_ms = ms_since(t);
    std::unique_ptr<CorrectiveBinding> cd;
    models::LoadedModel lm;
    if (argc > 4) {
      lm = models::load_checkpoint(argv[4]);
      cd = std::make_unique<CorrectiveBinding>(make_corrective_binding(
          ch, character_model_bones(lm, argv[4], models::Task::displacement), {},
          checkpoint_distortion_scales(lm.file, argv[4]), checkpoint_nearest_joints(lm.file, argv[4])));
      lm.model->fold_batch_norm();
    }
    std::vector<double> t_lbs, t_dm, t_arap, t_net;
    double d_dm = 0, d_arap = 0, e0 = 0, e1 = 0;
    for (int f = 0; f < F; ++f) {
      const Pose& pose = clip.frames[std::size_t(f)];
      t = Clock::now();
      const std::vector<float> lbs = linear_blend_skinning(w.mesh, skinning_matrices(w.skeleton, pose));
      t_lbs.push_back(ms_since(t));
      t = Clock::now();
      const std::vector<float> dm = delta_mush_apply(pc.delta_mush, lbs);
      t_dm.push_back(ms_since(t));
      t = Clock::now();
      const std::vector<float> ar = arap_apply(arap, lbs);
      t_arap.push_back(ms_since(t));
      d_dm += mean_distance(dm, lbs) / F;
      d_arap += mean_distance(ar, lbs) / F;
      e0 += arap_energy(arap, lbs) / F;
      e1 += arap_energy(arap, ar) / F;
      if (cd) {
        t = Clock::now();
        (void)deform_frame(*cd, *lm.model, lm.norm, pose);
        t_net.push_back(ms_since(t));
      }
    }
    std::printf("reference_cost: %s, %lld vertices (%lld ARAP handles), %d frames of %s\n", argv[1],
                static_cast<long long>(w.mesh.num_vertices()), static_cast<long long>(arap.num_handles()), F, argv[2]);
    std::printf("  ARAP binding (cotangent weights + factorisation, once per character): %.1f ms\n", bind_ms);
    std::printf("  CPU time per frame (median): LBS %.2f ms, Delta Mush %.2f ms, ARAP (%d iterations) %.2f ms",
                median(t_lbs), median(t_dm), arap.params.iterations, median(t_arap));
    if (cd) std::printf(", DenseGATs (%s: features + inference) %.2f ms", lm.model->config().name.c_str(), median(t_net));
    std::printf("\n  mean distance to LBS (world units): Delta Mush %.5f, ARAP %.5f; ARAP energy LBS %.4g -> %.4g\n",
                d_dm, d_arap, e0, e1);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reference_cost: %s\n", e.what());
    return 1;
  }
  return 0;
}
