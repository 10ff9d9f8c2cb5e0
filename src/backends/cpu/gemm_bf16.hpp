#pragma once
// Internal: the bf16 inference product C = A B (inference.hpp's
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
// kBf16Nc, each its k blocks of kBf16Kc (even) in order; a block's columns,
// zero-padded to a multiple of 8 (at least 16), are cut into panels of
// bf16_panel_width columns, each kp = ceil(kc / 2) rows of that many 32-bit
// words, word (p, j) = (B[k0 + 2p, j] low half, B[k0 + 2p + 1, j] high half)
// as bf16 (an odd k's last pair has a zero high half): the operand VDPBF16PS
// multiplies pairwise with a broadcast (A[i, 2p], A[i, 2p + 1]). Panels are
// 32 wide (two vectors per row) while more than 80 columns are left, then one
// panel of the rest (16 to 80): a GAT block's 72 columns (64 + the 8-wide
// self stream) are one 72-wide panel, 4 vectors and a half vector (256-bit
// VDPBF16PS: half a 512-bit one's cost on CPUs that split 512-bit operations
// in two, as Zen 4 does; an 80-wide panel spent 10 % on zero columns).
// k block: 384 pairs, all of k for DenseGATs' products (k <= 504). Measured
// (one thread, [10000 x 392] x [392 x 72]): 3.7 ms at 768, 4.2 ms at 384,
// 4.4 ms at 192: fewer passes over C beat keeping the B panel in L1 (the
// panel streams from L2 with one load per 5-12 multiply-adds).
constexpr std::int64_t kBf16Kc = 768;
constexpr std::int64_t kBf16Nc = 512;
inline std::int64_t bf16_ncpad(std::int64_t nc) { return nc <= 16 ? 16 : (nc + 7) / 8 * 8; }
// Width of the panel starting at column jr of a block of nc columns.
// k: B's rows. A 64-wide rest over more than 128 pairs is two 32-wide panels:
// its 6 x 64 panel (64 KiB at k = 512) streams from L2 and ran at 2/3 of the
// 12 x 32 tile's rate (the head's 512 -> 128 layer).
inline int bf16_panel_width(std::int64_t k, std::int64_t nc, std::int64_t jr) {
  const std::int64_t rest = bf16_ncpad(nc) - jr;
  if (rest == 64 && k > 256) return 32;
  return rest <= 80 ? int(rest) : 32;
}
// Rows past a row block the kernel may read (its last register tile's, not stored).
constexpr std::int64_t kPadRows = 24;
std::int64_t packed_bf16_words(std::int64_t k, std::int64_t n);
// Start of the block (column block j0 of width nc, k block k0); its panel at
// column jr starts jr * kp words further.
inline std::int64_t packed_bf16_offset(std::int64_t k, std::int64_t j0, std::int64_t nc, std::int64_t k0) {
  return j0 * ((k + 1) / 2) + (k0 / 2) * bf16_ncpad(nc);
}
void pack_b_bf16(const float* b, std::int64_t ldb, std::int64_t k, std::int64_t n, std::uint32_t* dst);

// Whether the CPU has AVX512_BF16 (with AVX-512 F/BW/VL).
bool cpu_has_avx512_bf16();

// Rows [0, m) of C = A B: A [m, k] fp32 (ld lda, rounded to bf16 here), B
// packed by pack_b_bf16, C [m, n] (ld ldc) overwritten. Serial (the caller
// threads over row ranges). With `aw` non-null, A is read from there instead,
// already as bf16 pair words (row i at aw + i * ldw, ceil(k/2) words; rows up
// to m + kPadRows must be readable: a partial register tile reads them into
// rows it does not store).
// With `epi`: C's final values are not stored but finished in registers
// (+ bias, tanh) and written as bf16 pair words (row i at epi->words + i *
// epi->ldw); C then only holds partial sums when k spans several k blocks.
struct Bf16Epilogue {
  const float* bias = nullptr;  // n floats, or null
  bool tanh = false;
  std::uint32_t* words = nullptr;
  std::int64_t ldw = 0;
};
// With `accumulate`: C += A B (no epilogue), C summed as a further k block would be.
void gemm_bf16_avx512(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const std::uint32_t* bp,
                      std::int64_t n, float* c, std::int64_t ldc, const std::uint32_t* aw = nullptr,
                      std::int64_t ldw = 0, const Bf16Epilogue* epi = nullptr, bool accumulate = false);
// Training operands, packed per call (AVX512_BF16 CPUs only): X [k, n] is
// x[kk * rs + j * cs] with rs or cs equal to 1 (a row-major view or its
// transpose). pack_b_bf16_strided_avx512: pack_b_bf16's layout, bit for bit.
// bf16_pairs_strided_avx512: row i of X [m, k] (x[i * rs + kk * cs]) as
// ceil(k/2) pair words at out + i * ldw.
void pack_b_bf16_strided_avx512(const float* b, std::int64_t rs, std::int64_t cs, std::int64_t k, std::int64_t n,
                                std::uint32_t* dst);
void bf16_pairs_strided_avx512(const float* a, std::int64_t rs, std::int64_t cs, std::int64_t m, std::int64_t k,
                               std::uint32_t* out, std::int64_t ldw);
// x[0, count) as ceil(count/2) bf16 pair words (AVX512_BF16 CPUs only; the
// conversion gemm_bf16_avx512 applies to A's rows).
void bf16_pairs_avx512(const float* x, std::int64_t count, std::uint32_t* out);
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
