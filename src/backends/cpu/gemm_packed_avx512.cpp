// Serial packed sgemm for AVX-512: C = alpha op(A) op(B) + beta C on one
// tile of gemm()'s fixed tiling (gemm.cpp does the threading).
//
// Why not Eigen here: on the model's skinny shapes (8000 x 504 x 64/512 and
// their transposed backward variants) Eigen's AVX-512 product spends a
// sixth of its time re-packing its right-hand side and reaches about 60
// GFLOP/s per core. This is the classic three-level blocking (k blocks of
// kKc, row blocks of kMc, register tiles of MR x NR), with B packed into
// contiguous panels so that the transposes backward needs cost nothing in
// the inner loop:
//   - B panel: kc x NR (NR = 32, two zmm per row; 16 when n <= 16, for the
//     GAT blocks' 8-wide self stream), zero-padded on the right;
//   - A: read in place (rows, or columns when transposed); only a bottom
//     partial tile of MR rows is packed, zero-padded;
//   - micro-kernel: MR x NR accumulators in registers (12 x 2 or 24 x 1 zmm),
//     one broadcast FMA per row and vector per k; a last panel of <= 16
//     columns (the GAT blocks' n = 72 = 64 + 8) runs 12 x 1 on it, with
//     the same sums (a 12 x 2 tile there spent half its FMAs on masked
//     lanes: a quarter of those products' time).
// Every C element is summed over k in one fixed order (k blocks in order,
// then k within a block), a function of the shape only: results do not
// depend on the thread count.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/target_region.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
GATCORE_TARGET_BEGIN("avx512f,avx2,fma")
#if !defined(__clang__)
// GCC 12 warns inside its own _mm512_undefined_ps() (used by the shuffle
// intrinsics of transpose16) that the deliberately undefined value "may be
// used uninitialized" (GCC bug 105593); nothing here reads uninitialised data.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include "src/backends/cpu/transpose16_avx512.hpp"

namespace gatcore::cpu::detail {
namespace {

#ifndef GATCORE_GEMM_KC  // (overridable for tuning experiments)
#define GATCORE_GEMM_KC 192
#endif
constexpr std::int64_t kKc = GATCORE_GEMM_KC;  // k block: a 32-wide B panel (24 KiB) stays in L1
constexpr std::int64_t kMc = 120;  // row block: its A rows (90 KiB) stay in L2 across the B panels
constexpr std::int64_t kNc = 512;  // column block: the packed B block (384 KiB) stays in L2
// A row block of a row-major op(A) is packed (contiguous MR-row panels) when
// at least this many columns reuse it: reading A in place costs 12 strided
// cache lines per k (and, for power-of-two row strides, 12 lines in one L1
// set); packing costs one pass over the block, worth it when the block feeds
// >= 4 B panels.
#ifndef GATCORE_GEMM_PACK_A_MIN_N
#define GATCORE_GEMM_PACK_A_MIN_N 128
#endif
constexpr std::int64_t kPackAMinN = GATCORE_GEMM_PACK_A_MIN_N;

struct Buffers {
  float* a = nullptr;
  float* b = nullptr;
  Buffers() {
    a = static_cast<float*>(std::aligned_alloc(64, sizeof(float) * kMc * kKc));  // one packed row block
    b = static_cast<float*>(std::aligned_alloc(64, sizeof(float) * kKc * kNc));
  }
  ~Buffers() {
    std::free(a);
    std::free(b);
  }
  Buffers(const Buffers&) = delete;
  Buffers& operator=(const Buffers&) = delete;
};

// dst[k * ld + c] = src[c * lds + k] for c < rows (<= 16), k < kc: `rows`
// contiguous source rows written as kc destination rows of `rows` values
// (the transposing copy both packings need). 16 x 16 blocks go through
// registers (a scalar copy writes one float per store, scattered over kc
// cache lines, and cost a quarter of a product's time); the k tail is scalar.
inline void transpose_copy(const float* src, std::int64_t lds, int rows, std::int64_t kc, float* dst,
                           std::int64_t ld) {
  const __mmask16 rmask = rows >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rows) - 1u);
  std::int64_t k = 0;
  for (; k + 16 <= kc; k += 16) {
    __m512 r[16];
#pragma GCC unroll 16
    for (int c = 0; c < 16; ++c) r[c] = c < rows ? _mm512_loadu_ps(src + c * lds + k) : _mm512_setzero_ps();
    transpose16(r);
#pragma GCC unroll 16
    for (int kk = 0; kk < 16; ++kk) _mm512_mask_storeu_ps(dst + (k + kk) * ld, rmask, r[kk]);
  }
  for (; k < kc; ++k)
    for (int c = 0; c < rows; ++c) dst[k * ld + c] = src[c * lds + k];
}

// Packs rows [i0, i0+mc) x k [k0, k0+kc) of op(A) into MR-row panels.
void pack_a(const GemmArgs& g, std::int64_t i0, std::int64_t mc, std::int64_t k0, std::int64_t kc, int mr,
            float* dst) {
  for (std::int64_t ir = 0; ir < mc; ir += mr) {
    const std::int64_t rows = std::min<std::int64_t>(mr, mc - ir);
    float* p = dst + ir * kc;
    if (g.trans_a) {
      // op(A)(i, k) = A[k, i]: contiguous in i.
      for (std::int64_t k = 0; k < kc; ++k) {
        const float* src = g.a + (k0 + k) * g.lda + i0 + ir;
        float* d = p + k * mr;
        std::int64_t r = 0;
        for (; r < rows; ++r) d[r] = src[r];
        for (; r < mr; ++r) d[r] = 0.0f;
      }
    } else if (mr <= 16) {
      const float* src = g.a + (i0 + ir) * g.lda + k0;
      transpose_copy(src, g.lda, int(rows), kc, p, mr);
      for (std::int64_t r = rows; r < mr; ++r)
        for (std::int64_t k = 0; k < kc; ++k) p[k * mr + r] = 0.0f;
    } else {
      for (std::int64_t r = 0; r < rows; ++r) {
        const float* src = g.a + (i0 + ir + r) * g.lda + k0;
        for (std::int64_t k = 0; k < kc; ++k) p[k * mr + r] = src[k];
      }
      for (std::int64_t r = rows; r < mr; ++r)
        for (std::int64_t k = 0; k < kc; ++k) p[k * mr + r] = 0.0f;
    }
  }
}

// Packs k [k0, k0+kc) x columns [j0, j0+nc) of op(B) into NR-column panels.
void pack_b(const GemmArgs& g, std::int64_t k0, std::int64_t kc, std::int64_t j0, std::int64_t nc, int nr,
            float* dst) {
  for (std::int64_t jr = 0; jr < nc; jr += nr) {
    const std::int64_t cols = std::min<std::int64_t>(nr, nc - jr);
    float* p = dst + jr * kc;
    if (g.trans_b) {
      // op(B)(k, j) = B[j, k]: contiguous in k; 16 columns at a time.
      for (std::int64_t c0 = 0; c0 < cols; c0 += 16)
        transpose_copy(g.b + (j0 + jr + c0) * g.ldb + k0, g.ldb, int(std::min<std::int64_t>(16, cols - c0)), kc,
                       p + c0, nr);
      for (std::int64_t c = cols; c < nr; ++c)
        for (std::int64_t k = 0; k < kc; ++k) p[k * nr + c] = 0.0f;
    } else {
      for (std::int64_t k = 0; k < kc; ++k) {
        const float* src = g.b + (k0 + k) * g.ldb + j0 + jr;
        float* d = p + k * nr;
        std::int64_t c = 0;
        for (; c < cols; ++c) d[c] = src[c];
        for (; c < nr; ++c) d[c] = 0.0f;
      }
    }
  }
}

// C[0:mr_eff, 0:nr_eff] = alpha * (A tile . B panel) + beta * C (beta = 0: C
// is not read, so NaN / uninitialised memory there is ignored). A tile
// element (r, k) is at a[r * sr + k * sk]: ROWS = true reads MR rows of a
// row-major op(A) in place (sr = lda, sk = 1); ROWS = false reads a packed
// panel (sr = 1, sk = MR) or a transposed A in place (sr = 1, sk = lda).
// BS: floats per k of the B panel (its NR; a 1-vector kernel on the last,
// narrow panel of a 2-vector product reads that product's wider panel).
template <int MR, int NV, bool ROWS, int BS = 16 * NV>
void micro_kernel(std::int64_t kc, const float* __restrict a, std::int64_t stride, const float* __restrict bp,
                  float* c, std::int64_t ldc, int mr_eff, int nr_eff, float alpha, float beta) {
  __m512 acc[MR][NV];
#pragma GCC unroll 32
  for (int r = 0; r < MR; ++r)
#pragma GCC unroll 2
    for (int v = 0; v < NV; ++v) acc[r][v] = _mm512_setzero_ps();
  for (std::int64_t k = 0; k < kc; ++k) {
    __m512 b[NV];
#pragma GCC unroll 2
    for (int v = 0; v < NV; ++v) b[v] = _mm512_load_ps(bp + k * BS + 16 * v);
    const float* ak = ROWS ? a + k : a + k * stride;
#pragma GCC unroll 32
    for (int r = 0; r < MR; ++r) {
      const __m512 x = _mm512_set1_ps(ROWS ? ak[r * stride] : ak[r]);
#pragma GCC unroll 2
      for (int v = 0; v < NV; ++v) acc[r][v] = _mm512_fmadd_ps(x, b[v], acc[r][v]);
    }
  }
  __mmask16 mask[NV];
#pragma GCC unroll 2
  for (int v = 0; v < NV; ++v) {
    const int rem = nr_eff - 16 * v;
    mask[v] = rem >= 16 ? __mmask16(0xFFFF) : rem <= 0 ? __mmask16(0) : __mmask16((1u << rem) - 1u);
  }
  const __m512 va = _mm512_set1_ps(alpha), vb = _mm512_set1_ps(beta);
#pragma GCC unroll 32
  for (int r = 0; r < MR; ++r) {
    if (r >= mr_eff) break;
    float* crow = c + r * ldc;
#pragma GCC unroll 2
    for (int v = 0; v < NV; ++v) {
      __m512 x = _mm512_mul_ps(va, acc[r][v]);
      if (beta != 0.0f) x = _mm512_fmadd_ps(vb, _mm512_maskz_loadu_ps(mask[v], crow + 16 * v), x);
      _mm512_mask_storeu_ps(crow + 16 * v, mask[v], x);
    }
  }
}

// Where the packed B block (k block k0, column block j0) of the whole op(B)
// [k, n] sits in a pre-packed B (prepack_b_avx512): column blocks in order,
// each its k blocks in order, a block kc x (nc rounded up to NR). Every column
// block but the last is kNc wide (a multiple of NR), so block j0 starts at j0 * k.
inline std::int64_t prepacked_offset(std::int64_t k, std::int64_t j0, std::int64_t nc, std::int64_t k0, int nr) {
  return j0 * k + k0 * ((nc + nr - 1) / nr * nr);
}

// `prepacked`: op(B) already packed by prepack_b_avx512 (constant weights,
// packed once), or null to pack each block here. The arithmetic is the same
// either way.
template <int MR, int NV>
void gemm_blocked(const GemmArgs& g, std::int64_t k, Buffers& buf, const float* prepacked = nullptr) {
  constexpr int NR = 16 * NV;
  static_assert(kMc % MR == 0, "row blocks are whole register tiles");
  // Narrow products (n < kPackAMinN) read A in place (its rows or,
  // transposed, its columns are contiguous enough) and pack only the bottom
  // partial tile of MR rows (zero-padded), so the kernel never reads past A:
  // with n = 64 a block feeds only two B panels and packing it cost as much
  // as the product. Wider products pack each row block once per k block,
  // unless A is transposed: then a tile's MR values per k are already
  // contiguous and in-place reads measured faster than packing (weight
  // gradients 94 vs 89 GFLOP/s per core).
  const bool pack_a_blocks = g.n >= kPackAMinN && !g.trans_a;
  for (std::int64_t j0 = 0; j0 < g.n; j0 += kNc) {
    const std::int64_t nc = std::min(kNc, g.n - j0);
    for (std::int64_t k0 = 0; k0 < k; k0 += kKc) {
      const std::int64_t kc = std::min(kKc, k - k0);
      // The first k block applies the caller's beta; later ones accumulate.
      const float beta = k0 == 0 ? g.beta : 1.0f;
      const float* bblock = buf.b;
      if (prepacked)
        bblock = prepacked + prepacked_offset(k, j0, nc, k0, NR);
      else
        pack_b(g, k0, kc, j0, nc, NR, buf.b);
      const std::int64_t m_full = pack_a_blocks ? g.m : g.m / MR * MR;
      if (m_full < g.m) pack_a(g, m_full, g.m - m_full, k0, kc, MR, buf.a);
      for (std::int64_t i0 = 0; i0 < g.m; i0 += kMc) {
        const std::int64_t mc = std::min(kMc, g.m - i0);
        if (pack_a_blocks) pack_a(g, i0, mc, k0, kc, MR, buf.a);
        for (std::int64_t jr = 0; jr < nc; jr += NR) {
          const int nr_eff = int(std::min<std::int64_t>(NR, nc - jr));
          const float* bp = bblock + jr * kc;
          // The register tiles down the row block, NVK vectors wide.
          const auto tiles = [&]<int NVK>() {
            for (std::int64_t ir = 0; ir < mc; ir += MR) {
              const std::int64_t i = i0 + ir;
              float* c = g.c + i * g.ldc + j0 + jr;
              const int mr_eff = int(std::min<std::int64_t>(MR, g.m - i));
              if (pack_a_blocks)
                micro_kernel<MR, NVK, false, NR>(kc, buf.a + ir * kc, MR, bp, c, g.ldc, mr_eff, nr_eff, g.alpha, beta);
              else if (i >= m_full)
                micro_kernel<MR, NVK, false, NR>(kc, buf.a, MR, bp, c, g.ldc, mr_eff, nr_eff, g.alpha, beta);
              else if (g.trans_a)
                micro_kernel<MR, NVK, false, NR>(kc, g.a + k0 * g.lda + i, g.lda, bp, c, g.ldc, MR, nr_eff, g.alpha,
                                                 beta);
              else
                micro_kernel<MR, NVK, true, NR>(kc, g.a + i * g.lda + k0, g.lda, bp, c, g.ldc, MR, nr_eff, g.alpha,
                                                beta);
            }
          };
          // A last panel of <= 16 columns (n = 72: 64 + 8) runs the tile of
          // one vector per row on the same panel: half the FMAs of a
          // two-vector tile whose second vector is all mask, the same sums.
          if (NV == 2 && nr_eff <= 16)
            tiles.template operator()<1>();
          else
            tiles.template operator()<NV>();
        }
      }
    }
  }
}

// ---- transposed A, n <= 8 (weight gradients of the GAT blocks' 8-wide self
// stream and of the 3-wide output layer) ----------------------------------
// With so few columns the register tile above wastes half of each vector and
// is bound by its broadcasts. With A transposed, C's columns are contiguous
// in A's rows, so this kernel vectorises along m instead, op(B) (k x n,
// small) copied to a contiguous buffer. (The row-major-A counterpart, a
// dot-product formulation, measured no faster than the register tile and is
// not used.)

// op(B) as bt[j * kpad + kk] (kpad = k rounded up to 16, zero-padded): one
// contiguous row of k per output column.
void pack_b_columns(const GemmArgs& g, std::int64_t k, std::int64_t kpad, float* bt) {
  for (std::int64_t j = 0; j < g.n; ++j) {
    float* d = bt + j * kpad;
    for (std::int64_t kk = 0; kk < k; ++kk) d[kk] = g.trans_b ? g.b[j * g.ldb + kk] : g.b[kk * g.ldb + j];
    for (std::int64_t kk = k; kk < kpad; ++kk) d[kk] = 0.0f;
  }
}

inline float combine(float acc, float* c, float alpha, float beta) {
  return beta == 0.0f ? alpha * acc : alpha * acc + beta * *c;
}

// Transposed op(A) (A stored [k, m]): C[i..i+48, j] accumulate A[kk, i..i+48]
// times op(B)(kk, j), straight from A's contiguous rows; k in order.
template <int N>
void narrow_cols(const GemmArgs& g, std::int64_t k, const float* bt, std::int64_t kpad) {
  constexpr int V = 3;
  for (std::int64_t i0 = 0; i0 < g.m; i0 += 16 * V) {
    __mmask16 mask[V];
    for (int v = 0; v < V; ++v) {
      const std::int64_t rem = g.m - i0 - 16 * v;
      mask[v] = rem >= 16 ? __mmask16(0xFFFF) : rem <= 0 ? __mmask16(0) : __mmask16((1u << rem) - 1u);
    }
    __m512 acc[V][N];
#pragma GCC unroll 3
    for (int v = 0; v < V; ++v)
#pragma GCC unroll 8
      for (int j = 0; j < N; ++j) acc[v][j] = _mm512_setzero_ps();
    for (std::int64_t kk = 0; kk < k; ++kk) {
      const float* arow = g.a + kk * g.lda + i0;
      __m512 a[V];
#pragma GCC unroll 3
      for (int v = 0; v < V; ++v) a[v] = _mm512_maskz_loadu_ps(mask[v], arow + 16 * v);
#pragma GCC unroll 8
      for (int j = 0; j < N; ++j) {
        const __m512 b = _mm512_set1_ps(bt[j * kpad + kk]);
#pragma GCC unroll 3
        for (int v = 0; v < V; ++v) acc[v][j] = _mm512_fmadd_ps(a[v], b, acc[v][j]);
      }
    }
    alignas(64) float t[16];
    for (int v = 0; v < V; ++v) {
      const std::int64_t lanes = std::min<std::int64_t>(16, g.m - i0 - 16 * v);
      for (int j = 0; j < N; ++j) {
        _mm512_store_ps(t, acc[v][j]);
        for (std::int64_t l = 0; l < lanes; ++l) {
          float* c = g.c + (i0 + 16 * v + l) * g.ldc + j;
          *c = combine(t[l], c, g.alpha, g.beta);
        }
      }
    }
  }
}

void gemm_narrow(const GemmArgs& g, std::int64_t k) {
  thread_local std::vector<float> bt;
  const std::int64_t kpad = (k + 15) / 16 * 16;
  bt.resize(static_cast<std::size_t>(kpad * g.n));
  pack_b_columns(g, k, kpad, bt.data());
  switch (g.n) {
    case 1: narrow_cols<1>(g, k, bt.data(), kpad); break;
    case 2: narrow_cols<2>(g, k, bt.data(), kpad); break;
    case 3: narrow_cols<3>(g, k, bt.data(), kpad); break;
    case 4: narrow_cols<4>(g, k, bt.data(), kpad); break;
    case 5: narrow_cols<5>(g, k, bt.data(), kpad); break;
    case 6: narrow_cols<6>(g, k, bt.data(), kpad); break;
    case 7: narrow_cols<7>(g, k, bt.data(), kpad); break;
    default: narrow_cols<8>(g, k, bt.data(), kpad); break;
  }
}

}  // namespace

void gemm_packed_avx512(const GemmArgs& g) {
  const std::int64_t k = g.trans_a ? g.a_rows : g.a_cols;
  if (g.m == 0 || g.n == 0) return;
  // gemm() handles k == 0 and alpha == 0 itself (C = beta C) before calling a tile kernel.
  if (g.n <= 8 && g.trans_a) return gemm_narrow(g, k);
  thread_local Buffers buf;
  if (g.n <= 16)
    gemm_blocked<24, 1>(g, k, buf);
  else
    gemm_blocked<12, 2>(g, k, buf);
}

// ---- pre-packed B (inference.hpp) --------------------------------------
// The panel width gemm_packed_avx512 uses for a product n columns wide.
int prepacked_nr_avx512(std::int64_t n) { return n <= 16 ? 16 : 32; }

std::int64_t prepacked_size_avx512(std::int64_t k, std::int64_t n) {
  const int nr = prepacked_nr_avx512(n);
  std::int64_t size = 0;
  for (std::int64_t j0 = 0; j0 < n; j0 += kNc) size += k * ((std::min(kNc, n - j0) + nr - 1) / nr * nr);
  return size;
}

void prepack_b_avx512(const GemmArgs& g, float* dst) {
  const std::int64_t k = g.trans_b ? g.b_cols : g.b_rows;
  const int nr = prepacked_nr_avx512(g.n);
  for (std::int64_t j0 = 0; j0 < g.n; j0 += kNc) {
    const std::int64_t nc = std::min(kNc, g.n - j0);
    for (std::int64_t k0 = 0; k0 < k; k0 += kKc)
      pack_b(g, k0, std::min(kKc, k - k0), j0, nc, nr, dst + prepacked_offset(k, j0, nc, k0, nr));
  }
}

void gemm_prepacked_avx512(const GemmArgs& g, const float* packed) {
  const std::int64_t k = g.trans_a ? g.a_rows : g.a_cols;
  if (g.m == 0 || g.n == 0) return;
  thread_local Buffers buf;
  if (prepacked_nr_avx512(g.n) == 16)
    gemm_blocked<24, 1>(g, k, buf, packed);
  else
    gemm_blocked<12, 2>(g, k, buf, packed);
}

}  // namespace gatcore::cpu::detail

GATCORE_TARGET_END
#endif
