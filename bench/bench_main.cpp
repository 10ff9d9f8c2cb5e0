// gatbench's main: Google Benchmark's, plus the run's context (SIMD path,
// OpenMP threads, mesh model) in the report header and JSON output.
// Benchmarks live in the other bench/*.cpp files; a new file there is picked
// up by bench/CMakeLists.txt without further changes.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <string>

#include "bench/bench_util.hpp"
#include "kernels/simd.hpp"

int main(int argc, char** argv) {
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
