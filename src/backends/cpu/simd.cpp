#include "src/backends/cpu/simd.hpp"

#include "gatcore/backend.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>

namespace gatcore::cpu {

SimdLevel detected_simd_level() {
#if defined(__x86_64__) || defined(__i386__)
  static const SimdLevel best = [] {
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("fma"))
      return SimdLevel::avx512;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return SimdLevel::avx2;
    return SimdLevel::scalar;
  }();
  return best;
#else
  return SimdLevel::scalar;
#endif
}

static SimdLevel initial_level() {
  SimdLevel best = detected_simd_level();
  if (const char* env = std::getenv("GATCORE_SIMD")) {
    SimdLevel want = best;
    if (!std::strcmp(env, "scalar")) want = SimdLevel::scalar;
    else if (!std::strcmp(env, "avx2")) want = SimdLevel::avx2;
    else if (!std::strcmp(env, "avx512")) want = SimdLevel::avx512;
    if (want < best) best = want;
  }
  return best;
}

static std::atomic<int> g_level{-1};

SimdLevel simd_level() {
  int l = g_level.load(std::memory_order_relaxed);
  if (l < 0) {
    l = static_cast<int>(initial_level());
    g_level.store(l, std::memory_order_relaxed);
  }
  return static_cast<SimdLevel>(l);
}

void set_simd_level(SimdLevel level) {
  SimdLevel best = detected_simd_level();
  g_level.store(static_cast<int>(level < best ? level : best), std::memory_order_relaxed);
}

const char* simd_level_name(SimdLevel level) {
  switch (level) {
    case SimdLevel::scalar: return "scalar";
    case SimdLevel::avx2: return "avx2";
    case SimdLevel::avx512: return "avx512";
  }
  return "?";
}

}  // namespace gatcore::cpu

namespace gatcore {

const char* cpu_simd_level_name() { return cpu::simd_level_name(cpu::simd_level()); }
const char* cpu_detected_simd_level_name() { return cpu::simd_level_name(cpu::detected_simd_level()); }

}  // namespace gatcore
