// The AVX512_BF16 inference product (gemm_bf16.hpp): VDPBF16PS multiplies 16
// pairs of bf16 values per instruction and adds both products into 16 fp32
// accumulators, 32 multiply-adds where an fp32 FMA does 16, so the GEMMs of
// the deploy path (GEMM-bound: ~70 % of a paper-size DenseGATs frame) run at
// up to twice the fp32 rate.
//
// Blocking (as gemm_packed_avx512.cpp, halved operands): per call, rows in
// blocks of kMc: the block's A rows are rounded to bf16 pairs once (all of
// k, contiguous per row: kMc x k/2 words, in L2); B comes packed
// (pack_b_bf16, at bind) in kBf16Kc-deep panels (L1 / L2) while a register
// tile of MR rows x the panel's columns runs down the block (12 x 32 for
// wide products; one panel of all columns up to 80: 24 x 16, 12 x 24, 8 x 48,
// 6 x 64, 5 x 72, 5 x 80, so a GAT block's 72 columns are one 5 x 72 tile
// with 4.5 vectors of multiply-adds per broadcast of A). Each C element sums its k blocks in order, a function
// of the shape only: results do not depend on the thread count.
#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "src/backends/cpu/gemm_bf16.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
GATCORE_TARGET_BEGIN("avx512f,avx512bw,avx512vl,avx512dq,avx512bf16,avx2,fma")
// (GCC 12's -Wmaybe-uninitialized false positive inside its own AVX-512
// headers, PR 105593: see fast_math.hpp.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop

#include "src/backends/cpu/fast_math.hpp"
#include "src/backends/cpu/transpose16_avx512.hpp"

namespace gatcore::cpu::detail {
namespace {

constexpr std::int64_t kMc = 120;  // rows per block (a multiple of both register tiles' MR)

inline __mmask16 lanes(std::int64_t rem) {
  return rem >= 16 ? __mmask16(0xFFFF) : rem <= 0 ? __mmask16(0) : __mmask16((1u << rem) - 1u);
}

// Row r of A (k floats) as ceil(k/2) bf16 pair words (an odd k's last pair
// has a zero high half: the masked load reads zeros past k).
inline void convert_row(const float* a, std::int64_t k, std::uint32_t* dst) {
  std::int64_t kk = 0;
  for (; kk + 32 <= k; kk += 32) {
    const __m512 lo = _mm512_loadu_ps(a + kk), hi = _mm512_loadu_ps(a + kk + 16);
    _mm512_storeu_si512(dst + kk / 2, (__m512i)_mm512_cvtne2ps_pbh(hi, lo));
  }
  if (kk < k) {
    const __m512 lo = _mm512_maskz_loadu_ps(lanes(k - kk), a + kk);
    const __m512 hi = _mm512_maskz_loadu_ps(lanes(k - kk - 16), a + kk + 16);
    _mm512_mask_storeu_epi32(dst + kk / 2, lanes((k - kk + 1) / 2), (__m512i)_mm512_cvtne2ps_pbh(hi, lo));
  }
}

// A tile's epilogue (the last k block of a Bf16Epilogue product): bias and
// tanh columns from the tile's first, bf16 words of the tile's first row.
struct TileEpi {
  const float* bias = nullptr;
  bool tanh = false;
  std::uint32_t* words = nullptr;  // null: store C
  std::int64_t ldw = 0;
};

// C[0:mr_eff, 0:nr_eff] (+)= A tile . B panel over kp pairs: A tile row r at
// a + r * lda (pair words), B panel kp x NR words. With e.words: the sum
// (+ bias, tanh) goes out as bf16 pair words instead (C only read, for the
// earlier k blocks' partial sums).
// NV 16-wide vectors and, with HALF, 8 more columns in a 256-bit vector
// (panel width 16 NV + 8 HALF; the packed rows are that many words, so
// unaligned loads).
template <int MR, int NV, bool HALF>
void micro_kernel(std::int64_t kp, const std::uint32_t* __restrict a, std::int64_t lda,
                  const std::uint32_t* __restrict bp, float* c, std::int64_t ldc, int mr_eff, int nr_eff,
                  bool accumulate, const TileEpi& e) {
  constexpr int NR = 16 * NV + 8 * HALF;
  constexpr int NV1 = NV > 0 ? NV : 1;  // array sizes
  __m512 acc[MR][NV1];
  __m256 acch[MR];
#pragma GCC unroll 32
  for (int r = 0; r < MR; ++r) {
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) acc[r][v] = _mm512_setzero_ps();
    if constexpr (HALF) acch[r] = _mm256_setzero_ps();
  }
  for (std::int64_t p = 0; p < kp; ++p) {
    __m512bh b[NV1];
    __m256bh bh;
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) b[v] = (__m512bh)_mm512_loadu_si512(bp + p * NR + 16 * v);
    if constexpr (HALF) bh = (__m256bh)_mm256_loadu_si256(reinterpret_cast<const __m256i*>(bp + p * NR + 16 * NV));
#pragma GCC unroll 32
    for (int r = 0; r < MR; ++r) {
      const __m512i xi = _mm512_set1_epi32(int(a[r * lda + p]));
      const __m512bh x = (__m512bh)xi;
#pragma GCC unroll 8
      for (int v = 0; v < NV; ++v) acc[r][v] = _mm512_dpbf16_ps(acc[r][v], x, b[v]);
      if constexpr (HALF) acch[r] = _mm256_dpbf16_ps(acch[r], (__m256bh)_mm512_castsi512_si256(xi), bh);
    }
  }
  __mmask16 mask[NV1];
#pragma GCC unroll 8
  for (int v = 0; v < NV; ++v) mask[v] = lanes(nr_eff - 16 * v);
  const __mmask8 maskh = __mmask8(lanes(nr_eff - 16 * NV));
  if (e.words) {
    // add_row_bias's add, activation_forward's tanh (fastmath::tanh_avx512),
    // bf16_pairs' rounding: the composition's arithmetic, without its passes.
    // Lanes past nr_eff are zero (zero B padding, masked bias), so an odd
    // width's last word gets a zero high half; words past the row are not written.
    __m512 bias[NV1];
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) bias[v] = e.bias ? _mm512_maskz_loadu_ps(mask[v], e.bias + 16 * v) : _mm512_setzero_ps();
    const __m256 biash = HALF && e.bias ? _mm256_maskz_loadu_ps(maskh, e.bias + 16 * NV) : _mm256_setzero_ps();
#pragma GCC unroll 32
    for (int r = 0; r < MR; ++r) {
      if (r >= mr_eff) break;
      const float* crow = c + r * ldc;
      std::uint32_t* wrow = e.words + r * e.ldw;
#pragma GCC unroll 8
      for (int v = 0; v < NV; ++v) {
        __m512 x = acc[r][v];
        if (accumulate) x = _mm512_add_ps(x, _mm512_maskz_loadu_ps(mask[v], crow + 16 * v));
        if (e.bias) x = _mm512_add_ps(x, bias[v]);
        if (e.tanh) x = fastmath::tanh_avx512(x);
        _mm256_mask_storeu_epi32(wrow + 8 * v, __mmask8(lanes((nr_eff - 16 * v + 1) / 2)),
                                 (__m256i)_mm512_cvtneps_pbh(x));
      }
      if constexpr (HALF) {  // the same on 8 columns (tanh on the zero-extended vector)
        __m256 x = acch[r];
        if (accumulate) x = _mm256_add_ps(x, _mm256_maskz_loadu_ps(maskh, crow + 16 * NV));
        if (e.bias) x = _mm256_add_ps(x, biash);
        if (e.tanh) x = _mm512_castps512_ps256(fastmath::tanh_avx512(_mm512_zextps256_ps512(x)));
        _mm_mask_storeu_epi32(wrow + 8 * NV, __mmask8(lanes((nr_eff - 16 * NV + 1) / 2)),
                              (__m128i)_mm256_cvtneps_pbh(x));
      }
    }
    return;
  }
#pragma GCC unroll 32
  for (int r = 0; r < MR; ++r) {
    if (r >= mr_eff) break;
    float* crow = c + r * ldc;
#pragma GCC unroll 8
    for (int v = 0; v < NV; ++v) {
      __m512 x = acc[r][v];
      if (accumulate) x = _mm512_add_ps(x, _mm512_maskz_loadu_ps(mask[v], crow + 16 * v));
      _mm512_mask_storeu_ps(crow + 16 * v, mask[v], x);
    }
    if constexpr (HALF) {
      __m256 x = acch[r];
      if (accumulate) x = _mm256_add_ps(x, _mm256_maskz_loadu_ps(maskh, crow + 16 * NV));
      _mm256_mask_storeu_ps(crow + 16 * NV, maskh, x);
    }
  }
}

struct Buffer {
  std::uint32_t* a = nullptr;
  std::int64_t words = 0;
  ~Buffer() { std::free(a); }
  std::uint32_t* get(std::int64_t w) {
    if (w > words) {  // grows to the largest block seen, then reused (no allocation per frame)
      std::free(a);
      words = (w + 15) / 16 * 16;
      a = static_cast<std::uint32_t*>(std::aligned_alloc(64, sizeof(std::uint32_t) * std::size_t(words)));
    }
    return a;
  }
};

// Register tile rows for a panel of nv vector registers per row (16 columns
// each, or 8 for a half one): about 24 accumulators, and nv accumulators per
// broadcast of A (the broadcasts, not the multiply-adds, bound the narrow
// tiles: 24 x 16 ran at half the 12 x 32 tile's rate).
constexpr int mr_for(int nv) { return nv == 1 ? 24 : nv == 2 ? 12 : nv == 3 ? 8 : nv == 4 ? 6 : 5; }

// One panel (NV vectors + HALF wide) down a row block of mc rows.
// e: the panel's epilogue at the block's first row (words null: plain store).
template <int NV, bool HALF>
void panel_rows(std::int64_t mc, std::int64_t kp, const std::uint32_t* ab, std::int64_t lda_w,
                const std::uint32_t* panel, float* c, std::int64_t ldc, int nr_eff, bool accumulate, TileEpi e) {
  constexpr int MR = mr_for(NV + HALF);
  static_assert(kMc % MR == 0, "row blocks are whole register tiles");
  std::uint32_t* const w0 = e.words;
  for (std::int64_t ir = 0; ir < mc; ir += MR) {
    if (w0) e.words = w0 + ir * e.ldw;
    micro_kernel<MR, NV, HALF>(kp, ab + ir * lda_w, lda_w, panel, c + ir * ldc, ldc, int(std::min<std::int64_t>(MR, mc - ir)),
                         nr_eff, accumulate, e);
  }
}

void gemm_rows(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const std::uint32_t* bp,
               std::int64_t n, float* c, std::int64_t ldc, const std::uint32_t* aw, std::int64_t ldw,
               const Bf16Epilogue* epi, bool accumulate) {
  const std::int64_t kp_all = (k + 1) / 2;
  // Converted row stride (words; rows 64-byte aligned), or the caller's pre-converted rows.
  const std::int64_t lda_w = aw ? ldw : (kp_all + 15) / 16 * 16;
  thread_local Buffer buf;
  std::uint32_t* conv = aw ? nullptr : buf.get((kMc + kPadRows) * lda_w);
  for (std::int64_t i0 = 0; i0 < m; i0 += kMc) {
    const std::int64_t mc = std::min(kMc, m - i0);
    const std::uint32_t* ab = aw ? aw + i0 * ldw : conv;
    if (!aw) {
      for (std::int64_t r = 0; r < mc; ++r) convert_row(a + (i0 + r) * lda, k, conv + r * lda_w);
      // Rows of the last partial register tile past m: zeros (read, never stored).
      std::fill(conv + mc * lda_w, conv + (mc + kPadRows) * lda_w, 0u);
    }
    for (std::int64_t j0 = 0; j0 < n; j0 += kBf16Nc) {
      const std::int64_t nc = std::min(kBf16Nc, n - j0);
      for (std::int64_t k0 = 0; k0 < k; k0 += kBf16Kc) {
        const std::int64_t kp = (std::min(kBf16Kc, k - k0) + 1) / 2;
        const std::uint32_t* block = bp + packed_bf16_offset(k, j0, nc, k0);
        for (std::int64_t jr = 0, w = 0; jr < nc; jr += w) {
          w = bf16_panel_width(k, nc, jr);
          const int nr_eff = int(std::min<std::int64_t>(w, nc - jr));
          const std::uint32_t* at = ab + k0 / 2;
          float* ct = c + i0 * ldc + j0 + jr;
          const std::uint32_t* panel = block + jr * kp;
          TileEpi e;
          if (epi && k0 + kBf16Kc >= k) {  // the last k block: the sums are final
            e.bias = epi->bias ? epi->bias + j0 + jr : nullptr;
            e.tanh = epi->tanh;
            e.words = epi->words + i0 * epi->ldw + (j0 + jr) / 2;  // j0 + jr even (multiples of 16)
            e.ldw = epi->ldw;
          }
          const bool acc = accumulate || k0 > 0;
          switch (w / 8) {  // 16 .. 80 columns, a multiple of 8
            case 2: panel_rows<1, false>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 3: panel_rows<1, true>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 4: panel_rows<2, false>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 5: panel_rows<2, true>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 6: panel_rows<3, false>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 7: panel_rows<3, true>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 8: panel_rows<4, false>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            case 9: panel_rows<4, true>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
            default: panel_rows<5, false>(mc, kp, at, lda_w, panel, ct, ldc, nr_eff, acc, e); break;
          }
        }
      }
    }
  }
}

// ---- training operands (gemm_bf16.hpp: pack_b_bf16_strided_avx512, bf16_pairs_strided_avx512) ----

// 16 pair words from two rows of 16 lanes: lane l = bf16(r0[l]) | bf16(r1[l]) << 16.
// One conversion of both rows (r0's 16 halves, then r1's) and one VPERMW
// interleaving them.
inline __m512i pairs_of_rows(__m512 r0, __m512 r1) {
  const __m512i both = (__m512i)_mm512_cvtne2ps_pbh(r1, r0);
  const __m512i interleave = _mm512_set_epi16(31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8, 23, 7,
                                              22, 6, 21, 5, 20, 4, 19, 3, 18, 2, 17, 1, 16, 0);
  return _mm512_permutexvar_epi16(interleave, both);
}
// 16 pair words from 32 consecutive values x[0, count) (zeros past count).
inline __m512i pairs_of_run(const float* x, std::int64_t count) {
  const __m512 lo = _mm512_maskz_loadu_ps(lanes(count), x), hi = _mm512_maskz_loadu_ps(lanes(count - 16), x + 16);
  return (__m512i)_mm512_cvtne2ps_pbh(hi, lo);
}
// transpose16 on 32-bit words (shuffles only: the bits move unchanged).
inline void transpose16_words(__m512i r[16]) {
  __m512 f[16];
#pragma GCC unroll 16
  for (int i = 0; i < 16; ++i) f[i] = _mm512_castsi512_ps(r[i]);
  transpose16(f);
#pragma GCC unroll 16
  for (int i = 0; i < 16; ++i) r[i] = _mm512_castps_si512(f[i]);
}

// Pair words of a [k, n] operand X(kk, j) = x[kk * rs + j * cs] (rs or cs 1)
// for pairs [p0, p0 + 16) and columns [j0, j0 + 16) (zeros outside [0, k) x
// [0, n)): out[q] = the 16 columns' words of pair p0 + q when `by_pair`, else
// out[c] = column j0 + c's 16 words. One transpose converts between the two.
inline void pair_block(const float* x, std::int64_t rs, std::int64_t cs, std::int64_t k, std::int64_t n,
                       std::int64_t p0, std::int64_t j0, bool by_pair, __m512i out[16]) {
  if (cs == 1) {  // rows contiguous in j: words by pair directly
    const __mmask16 mj = lanes(n - j0);
#pragma GCC unroll 16
    for (int q = 0; q < 16; ++q) {
      const std::int64_t kk = 2 * (p0 + q);
      const __m512 r0 = kk < k ? _mm512_maskz_loadu_ps(mj, x + kk * rs + j0) : _mm512_setzero_ps();
      const __m512 r1 = kk + 1 < k ? _mm512_maskz_loadu_ps(mj, x + (kk + 1) * rs + j0) : _mm512_setzero_ps();
      out[q] = pairs_of_rows(r0, r1);
    }
    if (!by_pair) transpose16_words(out);
  } else {  // columns contiguous in kk: words by column directly
#pragma GCC unroll 16
    for (int c = 0; c < 16; ++c)
      out[c] = j0 + c < n ? pairs_of_run(x + (j0 + c) * cs + 2 * p0, k - 2 * p0) : _mm512_setzero_si512();
    if (by_pair) transpose16_words(out);
  }
}

}  // namespace

void pack_b_bf16_strided_avx512(const float* b, std::int64_t rs, std::int64_t cs, std::int64_t k, std::int64_t n,
                                std::uint32_t* dst) {
  for (std::int64_t j0 = 0; j0 < n; j0 += kBf16Nc) {
    const std::int64_t nc = std::min(kBf16Nc, n - j0);
    const std::int64_t ncpad = bf16_ncpad(nc);
    for (std::int64_t k0 = 0; k0 < k; k0 += kBf16Kc) {
      const std::int64_t kc = std::min(kBf16Kc, k - k0), kp = (kc + 1) / 2;
      std::uint32_t* block = dst + packed_bf16_offset(k, j0, nc, k0);
      const float* xb = b + k0 * rs + j0 * cs;  // the block's (k0, j0)
      for (std::int64_t jr = 0, w = 0; jr < ncpad; jr += w) {
        w = bf16_panel_width(k, nc, jr);
        std::uint32_t* panel = block + jr * kp;
        for (std::int64_t p0 = 0; p0 < kp; p0 += 16)
          for (std::int64_t c0 = 0; c0 < w; c0 += 16) {  // w is a multiple of 8: the last group may be 8 wide
            __m512i v[16];
            pair_block(xb, rs, cs, kc, nc, p0, jr + c0, true, v);
            const __mmask16 mc = lanes(w - c0);
            for (std::int64_t q = 0; q < std::min<std::int64_t>(16, kp - p0); ++q)
              _mm512_mask_storeu_epi32(panel + (p0 + q) * w + c0, mc, v[q]);
          }
      }
    }
  }
}

void bf16_pairs_strided_avx512(const float* a, std::int64_t rs, std::int64_t cs, std::int64_t m, std::int64_t k,
                               std::uint32_t* out, std::int64_t ldw) {
  const std::int64_t kp = (k + 1) / 2;
  if (cs == 1) {  // rows contiguous: convert_row's conversion
    for (std::int64_t i = 0; i < m; ++i) convert_row(a + i * rs, k, out + i * ldw);
    return;
  }
  // Row i of op(A) is column i of a [k, m] row-major array (x(kk, i) = a[kk * cs + i]):
  // blocks of 16 rows x 16 pairs, transposed to rows.
  for (std::int64_t i0 = 0; i0 < m; i0 += 16)
    for (std::int64_t p0 = 0; p0 < kp; p0 += 16) {
      __m512i v[16];
      pair_block(a, cs, rs, k, m, p0, i0, false, v);
      const __mmask16 mp = lanes(kp - p0);
      for (std::int64_t c = 0; c < std::min<std::int64_t>(16, m - i0); ++c)
        _mm512_mask_storeu_epi32(out + (i0 + c) * ldw + p0, mp, v[c]);
    }
}

void gemm_bf16_avx512(const float* a, std::int64_t lda, std::int64_t m, std::int64_t k, const std::uint32_t* bp,
                      std::int64_t n, float* c, std::int64_t ldc, const std::uint32_t* aw, std::int64_t ldw,
                      const Bf16Epilogue* epi, bool accumulate) {
  if (m == 0 || n == 0) return;
  gemm_rows(a, lda, m, k, bp, n, c, ldc, aw, ldw, accumulate ? nullptr : epi, accumulate);
}

void bf16_pairs_avx512(const float* x, std::int64_t count, std::uint32_t* out) { convert_row(x, count, out); }

void bf16_convert_avx512(const float* x, std::int64_t count, std::uint16_t* out) {
  for (std::int64_t i = 0; i < count; i += 32) {
    std::uint32_t w[16];
    const std::int64_t rem = std::min<std::int64_t>(32, count - i);
    convert_row(x + i, rem, w);
    for (std::int64_t j = 0; j < rem; ++j) out[i + j] = std::uint16_t(j % 2 ? w[j / 2] >> 16 : w[j / 2] & 0xFFFFu);
  }
}

}  // namespace gatcore::cpu::detail

GATCORE_TARGET_END
#endif
