#pragma once
// Which SIMD fast path the CPU kernels take. Chosen once at run time from the
// CPU's features; GATCORE_SIMD=scalar|avx2|avx512 forces a lower level (tests
// use it to run every path against the reference).
namespace gatcore::cpu {

enum class SimdLevel { scalar = 0, avx2 = 1, avx512 = 2 };

SimdLevel simd_level();                 // current level (detected or forced)
void set_simd_level(SimdLevel level);   // clamps to what the CPU supports
SimdLevel detected_simd_level();        // best level the CPU supports
const char* simd_level_name(SimdLevel level);

}  // namespace gatcore::cpu
