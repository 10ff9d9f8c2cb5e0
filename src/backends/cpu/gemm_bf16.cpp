// The portable half of the bf16 product (gemm_bf16.hpp): B packing (done
// once per weight matrix, so plain scalar code), CPU detection, and the
// scalar emulation for CPUs without AVX512_BF16.
#include "src/backends/cpu/gemm_bf16.hpp"

#include <algorithm>
#include <vector>

namespace gatcore::cpu::detail {

std::int64_t packed_bf16_words(std::int64_t k, std::int64_t n) {
  std::int64_t words = 0;
  for (std::int64_t j0 = 0; j0 < n; j0 += kBf16Nc) words += (k + 1) / 2 * bf16_ncpad(std::min(kBf16Nc, n - j0));
  return words;
}

void pack_b_bf16(const float* b, std::int64_t ldb, std::int64_t k, std::int64_t n, std::uint32_t* dst) {
  auto at = [&](std::int64_t kk, std::int64_t j) -> std::uint32_t {
    return kk < k && j < n ? bf16_bits(b[kk * ldb + j]) : 0u;  // zero padding
  };
  for (std::int64_t j0 = 0; j0 < n; j0 += kBf16Nc) {
    const std::int64_t nc = std::min(kBf16Nc, n - j0);
    const std::int64_t ncpad = bf16_ncpad(nc);
    for (std::int64_t k0 = 0; k0 < k; k0 += kBf16Kc) {
      const std::int64_t kp = (std::min(kBf16Kc, k - k0) + 1) / 2;
      std::uint32_t* block = dst + packed_bf16_offset(k, j0, nc, k0);
      for (std::int64_t jr = 0, w = 0; jr < ncpad; jr += w) {
        w = bf16_panel_width(k, nc, jr);
        for (std::int64_t p = 0; p < kp; ++p)
          for (std::int64_t c = 0; c < w; ++c) {
            const std::int64_t j = j0 + jr + c, kk = k0 + 2 * p;
            // Padding columns inside the block (j >= j0 + nc) are zero too.
            const bool in = jr + c < nc;
            block[jr * kp + p * w + c] = in ? (at(kk, j) | (at(kk + 1, j) << 16)) : 0u;
          }
      }
    }
  }
}

bool cpu_has_avx512_bf16() {
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
  static const bool has = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bf16");
  }();
  return has;
#else
  return false;
#endif
}

void gemm_bf16_portable(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const float* b,
                        std::int64_t ldb, std::int64_t n, float* c, std::int64_t ldc) {
  std::vector<float> ar(static_cast<std::size_t>(k + 1), 0.0f), acc(static_cast<std::size_t>(n));
  for (std::int64_t i = 0; i < m; ++i) {
    for (std::int64_t kk = 0; kk < k; ++kk) ar[std::size_t(kk)] = bf16_round(a[i * lda + kk]);
    std::fill(acc.begin(), acc.end(), 0.0f);
    for (std::int64_t kk = 0; kk < k; kk += 2) {
      const float a0 = ar[std::size_t(kk)];
      const float* b0 = b + kk * ldb;
      if (kk + 1 < k) {
        const float a1 = ar[std::size_t(kk + 1)];
        const float* b1 = b0 + ldb;
        for (std::int64_t j = 0; j < n; ++j) acc[std::size_t(j)] += a1 * b1[j];
      }
      for (std::int64_t j = 0; j < n; ++j) acc[std::size_t(j)] += a0 * b0[j];
    }
    std::copy(acc.begin(), acc.end(), c + i * ldc);
  }
}

}  // namespace gatcore::cpu::detail
