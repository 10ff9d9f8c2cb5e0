// gatbench --gatbench_peak_rss=<workload>: a process that only builds one
// training workload and runs a few steps, so that its peak resident set
// (getrusage ru_maxrss) is the training step's and nothing else's.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bench/bench_models.hpp"

namespace gatbench {

namespace {
long max_rss_kib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;  // KiB on Linux
}
}  // namespace

int peak_rss_main(const std::string& name, int steps) {
  for (const auto& [bench, w] : train_workloads()) {
    if (bench != name) continue;
    if (w.precision == gatcore::Precision::bf16 && !gatcore::bf16_supported()) {
      std::fprintf(stderr, "gatbench: %s needs a CPU with AVX512_BF16\n", name.c_str());
      return 2;
    }
    ModelCase c(w.name, w.batch, w.vertices, w.precision);
    const long base = max_rss_kib();
    std::vector<double> ms;
    for (int s = 0; s < steps; ++s) {
      const auto t0 = std::chrono::steady_clock::now();
      c.step();
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(ms.begin(), ms.end());
    std::printf("%ld %ld %.3f\n", base, max_rss_kib(), ms[ms.size() / 2]);
    return 0;
  }
  std::fprintf(stderr, "gatbench: unknown workload '%s' for --gatbench_peak_rss (", name.c_str());
  for (const auto& [bench, w] : train_workloads()) std::fprintf(stderr, " %s", bench.c_str());
  std::fprintf(stderr, " )\n");
  return 2;
}

}  // namespace gatbench
