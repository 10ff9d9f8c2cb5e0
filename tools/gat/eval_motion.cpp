// gat eval --motion / --targets: the options into character::evaluate_motions,
// its log and tables printed, its JSON and Markdown written; the training
// logs' loss curves (--loss-curve) drawn beside the error maps.
#include "eval_motion.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "gatcore/atomic_file.hpp"
#include "gatcore/character/eval/motion_eval.hpp"
#include "gatcore/character/io/motion_source.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/error.hpp"
#include "progress.hpp"

using namespace gatcore;
using namespace gatcore::character;
namespace fs = std::filesystem;

namespace {

// The per-epoch losses of a `gat train` log.
std::vector<std::vector<float>> read_losses(const std::string& path) {
  std::ifstream f(path);
  GATCORE_CHECK(f.good(), path, ": cannot open the training log");
  std::vector<std::vector<float>> s(2);
  std::string line;
  while (std::getline(f, line)) {
    int e = 0, n = 0;
    float tr = 0, va = 0;
    if (std::sscanf(line.c_str(), "epoch %d/%d train loss %f val loss %f", &e, &n, &tr, &va) == 4) {
      s[0].push_back(tr);
      s[1].push_back(va);
    }
  }
  GATCORE_CHECK(!s[0].empty(), path, ": no 'epoch N/M  train loss X  val loss Y' lines");
  return s;
}

}  // namespace

int gat::eval_motion(const EvalMotionArgs& args) {
  GATCORE_CHECK(!args.data.empty(), "--motion / --targets need --data DATASET");
  GATCORE_CHECK(args.loss_curves.empty() || !args.errormaps.empty(),
                "--loss-curve writes into the --errormaps DIR; give one");
  MotionEvalOptions o;
  o.data = args.data;
  o.part = args.part;
  o.motion_paths = args.motions;
  for (const std::string& v : args.models) {
    const auto eq = v.find('=');
    o.models.emplace_back(eq == std::string::npos ? std::string() : v.substr(0, eq),
                          eq == std::string::npos ? v : v.substr(eq + 1));
  }
  o.stride = args.stride;
  o.errormaps = args.errormaps;
  o.errormap_frames = args.errormap_frames;
  o.errormap_size = args.errormap_size;
  o.cm_per_unit = args.cm_per_unit;
  o.max_limit_excess_deg = args.max_limit_excess_deg;
  o.linear_probe = args.linear_probe;
  for (const auto& p : o.motion_paths) o.motions.push_back(load_motion(p));

  // The dataset's characters are read first, then the frames evaluated: one progress line each.
  std::optional<gat::Progress> loading, progress;
  loading.emplace("preparing the characters of " + args.data, 0, "characters", args.quiet);
  const auto evaluating = [&](std::int64_t total) -> gat::Progress& {
    loading.reset();
    if (!progress) progress.emplace("evaluating " + args.part + " characters", total, "frames", args.quiet);
    return *progress;
  };
  MotionEvalHooks hooks;
  hooks.loading = loading->callback();
  hooks.progress = [&](std::int64_t done, std::int64_t total, const std::string& note) {
    evaluating(total).update(done, note);
  };
  const auto print = [&](const std::string& line) {
    loading.reset();
    if (progress) progress->finish();
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  };
  hooks.log = print;
  if (!args.quiet) hooks.row = print;
  hooks.warn = [&](const std::string& w) { std::fprintf(stderr, "gat eval: %s\n", w.c_str()); };
  const MotionEvalReport r = evaluate_motions(o, hooks);
  loading.reset();
  if (progress) progress->finish();
  for (const auto& lc : args.loss_curves) {
    const auto eq = lc.find('=');
    GATCORE_CHECK(eq != std::string::npos && eq > 0, "--loss-curve expects LABEL=LOG, got '", lc, "'");
    const auto series = read_losses(lc.substr(eq + 1));
    const std::string png = (fs::path(args.errormaps) / ("loss_" + lc.substr(0, eq) + ".png")).string();
    write_png(png, plot_curves(series, 480, 300, true));
    std::printf("  loss curve of %s (%zu epochs) -> %s\n", lc.substr(0, eq).c_str(), series[0].size(), png.c_str());
  }
  if (!args.json.empty()) write_file_atomic(args.json, r.json);
  if (!args.markdown.empty()) write_file_atomic(args.markdown, r.markdown);
  std::printf("%s", r.markdown.c_str());
  std::printf("gat eval: %zu methods on %zu characters in %.1f s\n", r.methods.size(), r.characters, r.seconds);
  return 0;
}
