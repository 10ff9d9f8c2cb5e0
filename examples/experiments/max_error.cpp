// max_error: where the largest LBS-vs-reference errors are (docs/RESULTS.md,
// "Max error"): for every STRIDE-th frame of MOTION on each test character of
// DATASET it computes |reference - LBS| per vertex (the dataset's reference
// deformer: what a network has to add) and reports
//   - the 99th percentile and the maximum over all vertex-frames,
//   - the worst frames (their maximum, the vertex, its dominant joint and
//     weight, and how many vertices are above 5 cm there),
//   - which joints the vertices above the overall 99.9th percentile belong to,
// and renders the worst frame's error map (front and side) into OUT_DIR.
//
//   max_error DATASET.json MOTION.bvh STRIDE OUT_DIR
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "gatcore/character/data/training_data.hpp"
#include "gatcore/character/io/bvh.hpp"
#include "gatcore/character/viz/render.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

struct Worst {
  double error = 0;
  std::size_t frame = 0;
  std::int64_t vertex = 0;
  std::int64_t above_5cm = 0;
};

std::pair<std::int32_t, float> dominant(const Mesh& m, std::int64_t v) {
  std::int32_t j = -1;
  float w = 0;
  for (std::int64_t k = m.weights.ptr[v]; k < m.weights.ptr[v + 1]; ++k)
    if (m.weights.weight[k] > w) w = m.weights.weight[k], j = m.weights.joint[k];
  return {j, w};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: max_error DATASET.json MOTION.bvh STRIDE OUT_DIR\n");
    return 2;
  }
  try {
    const TrainingData td = load_training_data(argv[1]);
    const Motion motion = load_bvh(argv[2]);
    const int stride = std::atoi(argv[3]);
    if (stride < 1) throw InvalidArgument(std::string("STRIDE must be >= 1, got '") + argv[3] + "'");
    const std::string out = argv[4];
    std::filesystem::create_directories(out);
    for (std::int32_t c : td.part(DatasetPart::test)) {
      const PreparedCharacter& pc = td.characters[std::size_t(c)];
      const Character& ch = pc.character;
      const Clip clip = retarget(motion, ch.skeleton, mat4_identity());
      const double cm = 100.0;  // glTF: metres
      std::vector<float> all;
      std::vector<Worst> frames;
      for (std::size_t f = 0; f < clip.frames.size(); f += std::size_t(stride)) {
        const std::vector<float> lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, clip.frames[f]));
        const std::vector<float> ref = (pc.reference ? pc.reference->deform(lbs, -1) : delta_mush_apply(pc.delta_mush, lbs));
        Worst w;
        w.frame = f;
        for (std::int64_t v = 0; v < ch.mesh.num_vertices(); ++v) {
          double d = 0;
          for (int a = 0; a < 3; ++a) d += (double(ref[3 * v + a]) - lbs[3 * v + a]) * (double(ref[3 * v + a]) - lbs[3 * v + a]);
          const double e = std::sqrt(d) * cm;
          all.push_back(float(e));
          if (e > w.error) w.error = e, w.vertex = v;
          w.above_5cm += e > 5.0;
        }
        frames.push_back(w);
      }
      std::vector<float> sorted = all;
      std::sort(sorted.begin(), sorted.end());
      const auto q = [&](double p) { return sorted[std::min(sorted.size() - 1, std::size_t(p * double(sorted.size())))]; };
      std::printf("%s: %zu frames x %lld vertices; |reference - LBS| mean %.4f cm, p99 %.3f, p99.9 %.3f, max %.3f cm\n",
                  td.description.characters[std::size_t(c)].c_str(), frames.size(),
                  static_cast<long long>(ch.mesh.num_vertices()), [&] {
                    double s = 0;
                    for (float e : all) s += e;
                    return s / double(all.size());
                  }(), q(0.99), q(0.999), sorted.back());
      std::sort(frames.begin(), frames.end(), [](const Worst& a, const Worst& b) { return a.error > b.error; });
      const std::vector<JointLimit> limits = td.description.joint_limits
                                                 ? td.description.joint_limits->limits_for(ch.skeleton)
                                                 : uniform_limits(ch.skeleton, td.description.pose_angle);
      for (std::size_t k = 0; k < std::min<std::size_t>(5, frames.size()); ++k) {
        const auto [j, w] = dominant(ch.mesh, frames[k].vertex);
        const LimitExcess ex = pose_limit_excess(ch.skeleton, pc.rest, clip.frames[frames[k].frame], limits, pc.normalisation.origin_joint);
        std::printf("  frame %4zu: max %.2f cm at vertex %lld (dominant joint %s, weight %.2f), %lld vertices above 5 cm;"
                    " pose outside the training limits by %.0f deg (%s, axis %d)\n",
                    frames[k].frame, frames[k].error, static_cast<long long>(frames[k].vertex),
                    j >= 0 ? ch.skeleton.names[std::size_t(j)].c_str() : "-", double(w),
                    static_cast<long long>(frames[k].above_5cm), double(ex.radians) * 180.0 / 3.14159265358979,
                    ex.joint >= 0 ? ch.skeleton.names[std::size_t(ex.joint)].c_str() : "-", ex.axis);
      }
      // Joints of the vertex-frames above the 99.9th percentile.
      const float top = q(0.999);
      std::map<std::string, std::int64_t> by_joint;
      const std::int64_t n = ch.mesh.num_vertices();
      for (std::size_t i = 0; i < all.size(); ++i)
        if (all[i] > top) {
          const auto [j, w] = dominant(ch.mesh, std::int64_t(i) % n);
          ++by_joint[j >= 0 ? ch.skeleton.names[std::size_t(j)] : "-"];
        }
      std::vector<std::pair<std::int64_t, std::string>> ranked;
      for (const auto& [name, count] : by_joint) ranked.emplace_back(count, name);
      std::sort(ranked.rbegin(), ranked.rend());
      std::printf("  vertex-frames above p99.9 (%.2f cm) by dominant joint:", double(top));
      for (std::size_t k = 0; k < std::min<std::size_t>(6, ranked.size()); ++k)
        std::printf(" %s %lld", ranked[k].second.c_str(), static_cast<long long>(ranked[k].first));
      std::printf("\n");
      // The worst frame, front and side, colour scale top = that frame's max.
      const Worst& w = frames.front();
      const std::vector<float> lbs = linear_blend_skinning(ch.mesh, skinning_matrices(ch.skeleton, clip.frames[w.frame]));
      const std::vector<float> ref = (pc.reference ? pc.reference->deform(lbs, -1) : delta_mush_apply(pc.delta_mush, lbs));
      std::vector<float> err(static_cast<std::size_t>(n));
      for (std::int64_t v = 0; v < n; ++v) {
        double d = 0;
        for (int a = 0; a < 3; ++a) d += (double(ref[3 * v + a]) - lbs[3 * v + a]) * (double(ref[3 * v + a]) - lbs[3 * v + a]);
        err[std::size_t(v)] = float(std::sqrt(d) * cm);
      }
      std::string label = td.description.characters[std::size_t(c)];
      label = std::filesystem::path(label).parent_path().filename().string() + "_" +
              std::filesystem::path(label).stem().string();
      for (const auto& [name, dir] : {std::pair{"front", Vec3{0, 0, -1}}, std::pair{"side", Vec3{-1, 0, 0}}}) {
        RenderOptions ro;
        ro.width = ro.height = 320;
        ro.view_dir = dir;
        const std::string png = out + "/" + label + "_" + std::filesystem::path(argv[2]).stem().string() + "_f" +
                                std::to_string(w.frame) + "_" + name + ".png";
        write_png(png, render_error_map(lbs, ch.mesh.triangles, err, ro));
        std::printf("  worst frame %zu -> %s\n", w.frame, png.c_str());
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "max_error: %s\n", e.what());
    return 1;
  }
  return 0;
}
