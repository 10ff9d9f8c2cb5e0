#pragma once
// Internal: the bf16 inference product C = A B (gemm_prepacked.hpp's
// Precision::bf16), A fp32 activations rounded to bfloat16 as they are
// packed, B constant weights rounded and packed once, products accumulated in
// fp32.
//
// Rounding (bf16_bits) is VCVTNEPS2BF16's, bit for bit: round to nearest
// even, a zero or denormal input becomes a zero of its sign, NaN stays a
// quiet NaN. The portable product (gemm_bf16_portable) is the scalar
// emulation CPUs without AVX512_BF16 run; gemm_bf16_avx512 is the
// VDPBF16PS kernel (gemm_bf16_avx512.cpp).
#include <cstdint>
#include <cstring>

namespace gatcore::cpu {

inline std::uint16_t bf16_bits(float x) {
  std::uint32_t u;
  std::memcpy(&u, &x, 4);
  const std::uint32_t exp = u & 0x7F800000u, man = u & 0x007FFFFFu;
  if (exp == 0) return std::uint16_t((u >> 16) & 0x8000u);            // zero, denormal -> signed zero
  if (exp == 0x7F800000u) {
    if (man == 0) return std::uint16_t(u >> 16);                      // infinity
    return std::uint16_t((u >> 16) | 0x0040u);                        // NaN: quiet, sign and top payload kept
  }
  return std::uint16_t((u + 0x7FFFu + ((u >> 16) & 1u)) >> 16);       // nearest even (may round to infinity)
}
inline float bf16_to_float(std::uint16_t b) {
  const std::uint32_t u = std::uint32_t(b) << 16;
  float x;
  std::memcpy(&x, &u, 4);
  return x;
}
inline float bf16_round(float x) { return bf16_to_float(bf16_bits(x)); }

namespace detail {

// Layout of a packed bf16 B ([k, n] row-major source): column blocks of
// kBf16Nc, each its k blocks of kBf16Kc (even) in order; a block holds
// NR-column panels, each kp = ceil(kc / 2) rows of NR 32-bit words, word
// (p, j) = (B[k0 + 2p, j] low half, B[k0 + 2p + 1, j] high half) as bf16
// (an odd k's last pair has a zero high half): the operand VDPBF16PS
// multiplies pairwise with a broadcast (A[i, 2p], A[i, 2p + 1]).
constexpr std::int64_t kBf16Kc = 384;  // 192 pairs: a 32-wide panel is 24 KiB, kept in L1
constexpr std::int64_t kBf16Nc = 512;
inline int bf16_nr(std::int64_t n) { return n <= 16 ? 16 : 32; }
std::int64_t packed_bf16_words(std::int64_t k, std::int64_t n);
inline std::int64_t packed_bf16_offset(std::int64_t k, std::int64_t j0, std::int64_t nc, std::int64_t k0, int nr) {
  return j0 * ((k + 1) / 2) + (k0 / 2) * ((nc + nr - 1) / nr * nr);
}
void pack_b_bf16(const float* b, std::int64_t ldb, std::int64_t k, std::int64_t n, std::uint32_t* dst);

// Whether the CPU has AVX512_BF16 (with AVX-512 F/BW/VL).
bool cpu_has_avx512_bf16();

// Rows [0, m) of C = A B: A [m, k] fp32 (ld lda, rounded to bf16 here), B
// packed by pack_b_bf16, C [m, n] (ld ldc) overwritten. Serial (the caller
// threads over row ranges).
void gemm_bf16_avx512(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const std::uint32_t* bp,
                      std::int64_t n, float* c, std::int64_t ldc);
// The same product without AVX512_BF16: `b` is B [k, n] already rounded to
// bf16 values (ld ldb); each pair accumulated as VDPBF16PS's definition
// does (C += A[2p+1] B[2p+1], then += A[2p] B[2p]; products of bf16 values
// are exact in fp32).
void gemm_bf16_portable(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const float* b,
                        std::int64_t ldb, std::int64_t n, float* c, std::int64_t ldc);
// VCVTNE2PS2BF16 on x[0, count) (AVX512_BF16 CPUs only): for the test that
// bf16_bits is the hardware's rounding.
void bf16_convert_avx512(const float* x, std::int64_t count, std::uint16_t* out);

}  // namespace detail
}  // namespace gatcore::cpu
