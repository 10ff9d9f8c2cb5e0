// Runtime benchmarks (runtime.hpp): one frame of runtime::Deformer::deform
// (LBS, features incl. the detail-distortion columns at scales 1,4,16, the
// deploy-path model, the correction back in character units) on procedural
// humanoids of about 2k, 5k and 10k vertices:
//   runtime_deform/<model>/verts:N
// models: "paper" = DenseGATs with the paper's sizes (3 modules x 6 blocks,
// 8 heads x 8, head 512-128; ~714k parameters on the real dataset's 56
// bones), "distilled" = Ori.GAT with its defaults (4 layers, 8 heads x 8)
// and the linear skip (the `gat distill --linear-skip` student). Fresh
// weights: speed does not depend on them.
// "_bf16": the same with Precision::bf16 products (AVX512_BF16 CPUs; skipped
// with an error elsewhere).
// Counters: features_ms / model_ms per frame (Deformer::last_timing), the
// vertex count actually generated, the model's parameters.
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include "bench/bench_util.hpp"
#include "gatcore/character/rig/pose.hpp"
#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/rig/super_skeleton.hpp"
#include "gatcore/models/checkpoint.hpp"
#include "gatcore/runtime.hpp"

namespace {

using namespace gatcore;
using namespace gatcore::character;

// The procedural humanoid whose vertex count is closest to `target`.
Character humanoid_near(std::int64_t target) {
  Character best;
  std::int64_t best_d = -1;
  for (int seg = 8; seg <= 40; seg += 4)
    for (int rings = 3; rings <= 24; rings += 1) {
      ProceduralOptions o;
      o.seed = 1;
      o.ring_segments = seg;
      o.rings_per_bone = rings;
      const std::int64_t n = procedural_character(o).mesh.num_vertices();  // cheap: milliseconds
      const std::int64_t d = std::abs(n - target);
      if (best_d < 0 || d < best_d) {
        best_d = d;
        best = procedural_character(o);
      }
      if (n > target) break;
    }
  return best;
}

struct RuntimeCase {
  Character ch;
  std::unique_ptr<runtime::Deformer> d;
  std::vector<float> globals, out;
};

RuntimeCase make_case(const std::string& which, std::int64_t vertices, Precision precision) {
  RuntimeCase c;
  c.ch = humanoid_near(vertices);
  std::vector<std::string> bones;
  for (const auto& n : c.ch.skeleton.names) bones.push_back(normalise_bone_name(n));
  const std::int64_t in = 6 + std::int64_t(bones.size()) + 3 * 3;  // distortion scales 1,4,16
  models::ModelConfig cfg = models::ModelConfig::defaults(which == "paper" ? "densegats" : "origat", in, 3);
  cfg.linear_skip = which == "distilled";
  auto m = models::make_model(cfg, 1);
  models::Normaliser norm;
  norm.mean = Tensor::zeros(1, in);
  norm.inv_std = Tensor::full(1, in, 1.f);
  std::string joined;
  for (const auto& b : bones) joined += (joined.empty() ? "" : ",") + b;
  const auto path = std::filesystem::temp_directory_path() /
                    ("gatbench_runtime_" + which + "_" + std::to_string(::getpid()) + ".gcm");
  models::save_checkpoint(path.string(), *m, norm,
                          {{"features", "densegats"}, {"skeleton", joined}, {"distortion_scales", "1,4,16"}});
  c.d = std::make_unique<runtime::Deformer>(
      runtime::Deformer::load(path.string(), runtime::DeviceChoice::cpu, precision));
  std::filesystem::remove(path);
  c.d->bind(c.ch.mesh, c.ch.skeleton);
  // A walking-like pose: every joint turned a little, the root moved.
  Pose p = bind_pose(c.ch.skeleton);
  for (std::size_t j = 0; j < p.local.size(); ++j)
    p.local[j].rotation = quat_normalize(
        quat_mul(p.local[j].rotation, quat_from_axis_angle({0.3f, 1.f, 0.2f}, 0.3f * std::sin(float(j)))));
  p.local[0].translation[2] += 0.3f;
  for (const Mat4& g : global_transforms(c.ch.skeleton, p)) c.globals.insert(c.globals.end(), g.begin(), g.end());
  c.out.resize(std::size_t(3 * c.ch.mesh.num_vertices()));
  return c;
}

void runtime_deform(benchmark::State& state, const std::string& which, Precision precision) {
  const std::int64_t target = state.range(0);
  if (precision == Precision::bf16 && !bf16_supported()) {
    state.SkipWithError("bf16: this CPU has no AVX512_BF16");
    return;
  }
  auto& c = const_cast<RuntimeCase&>(gatbench::cached<RuntimeCase>(
      which + precision_name(precision) + std::to_string(target), [&] { return make_case(which, target, precision); }));
  const std::int64_t n = c.ch.mesh.num_vertices();
  state.SetLabel(std::to_string(n) + " vertices, " + std::to_string(c.d->parameter_count()) + " parameters");
  double features = 0, model = 0;
  std::int64_t frames = 0;
  gatbench::run(state, gatbench::Cost{0, 0, n}, [&] {
    c.d->deform(c.globals, c.out);
    features += c.d->last_timing().features_ms;
    model += c.d->last_timing().model_ms;
    ++frames;
  });
  state.counters["features_ms"] = features / double(std::max<std::int64_t>(frames, 1));
  state.counters["model_ms"] = model / double(std::max<std::int64_t>(frames, 1));
  state.counters["vertices"] = double(n);
}

BENCHMARK_CAPTURE(runtime_deform, paper, std::string("paper"), Precision::fp32)
    ->ArgName("verts")->Arg(2000)->Arg(5000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runtime_deform, distilled, std::string("distilled"), Precision::fp32)
    ->ArgName("verts")->Arg(2000)->Arg(5000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runtime_deform, paper_bf16, std::string("paper"), Precision::bf16)
    ->ArgName("verts")->Arg(2000)->Arg(5000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(runtime_deform, distilled_bf16, std::string("distilled"), Precision::bf16)
    ->ArgName("verts")->Arg(2000)->Arg(5000)->Arg(10000)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
