// gatbench's main: Google Benchmark's, plus the run's context (SIMD path,
// OpenMP threads, mesh model) in the report header and JSON output.
// Benchmarks live in the other bench/*.cpp files; a new file there is picked
// up by bench/CMakeLists.txt without further changes.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "bench/bench_models.hpp"
#include "bench/bench_util.hpp"
#include "src/backends/cpu/simd.hpp"

int main(int argc, char** argv) {
  // Child mode of model_peak_rss: nothing but one training workload.
  const std::string flag = "--gatbench_peak_rss=";
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]).rfind(flag, 0) == 0) {
      // NAME or NAME:STEPS (default 3 steps)
      std::string arg = argv[i] + flag.size();
      const auto colon = arg.find(':');
      const int steps = colon == std::string::npos ? 3 : std::max(1, std::atoi(arg.c_str() + colon + 1));
      return gatbench::peak_rss_main(arg.substr(0, colon), steps);
    }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::AddCustomContext("gatcore_simd", gatcore::cpu::simd_level_name(gatcore::cpu::simd_level()));
  benchmark::AddCustomContext("omp_max_threads", std::to_string(omp_get_max_threads()));
  benchmark::AddCustomContext("mesh", "patches of " + std::to_string(gatbench::kPatchCols) + "x" +
                                          std::to_string(gatbench::kPatchRows) +
                                          " vertices, triangulated grid, self-loops");
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
