// One tile of gemm(..., Precision::bf16) (gemm.hpp), the training products:
// C = alpha op(A) op(B) + beta C with both operands rounded to bf16 (round to
// nearest even, bf16_bits) and products accumulated in fp32. gemm() does the
// tiling and threading as for fp32 (1024 x 1024 tiles), so results do not
// depend on the thread count.
//
// The inference pieces do the work (gemm_bf16.hpp): operands change every
// step (weights after each Adam step, activations always), so both are
// converted per call: op(B) into pack_b_bf16's panels, op(A) by the kernel's
// own row conversion when A is row-major, else (the weight gradient A^T dY,
// A's columns are op(A)'s rows) into pair words by a 16 x 16 transposing
// conversion. k runs in chunks of kBf16Kc, the kernel's own k block, each
// chunk's operands converted just before it is used (a chunk's 512-column
// block of B is 768 KiB, the 1 MiB L2's worth the kernel runs a row block of A
// over), its sums added to C in chunk order: the same arithmetic as one call
// over all of k. CPUs without AVX512_BF16 run the scalar emulation (gemm_bf16_portable)
// on the same chunks, summed the same way: the same results but for denormal
// partial sums, which VDPBF16PS flushes to zero.
#include <algorithm>
#include <vector>

#include "src/backends/cpu/gemm_bf16.hpp"
#include "src/backends/cpu/gemm_impl.hpp"

namespace gatcore::cpu::detail {

namespace {
// Reused per thread (grown to the largest tile seen: at most 384 x 1024 words
// for B, 1048 x 384 words for A, 1024 x 1024 floats for the alpha / beta pass).
thread_local std::vector<std::uint32_t> t_bpack, t_apairs;
thread_local std::vector<float> t_acc, t_portable_a, t_portable_b, t_portable_c;

// op(X)(i, j) = x[i * rs + j * cs] for a stored [rows, cols] X with leading dimension ld.
struct Strides {
  std::int64_t rs, cs;
};
Strides op_strides(bool trans, std::int64_t ld) { return trans ? Strides{1, ld} : Strides{ld, 1}; }

// acc [m, n] (ld n) = op(A)[:, k0:k0+kc] op(B)[k0:k0+kc, :], or += when `accumulate`.
void chunk_avx512(const GemmArgs& g, Strides a, Strides b, std::int64_t k0, std::int64_t kc, float* acc,
                  std::int64_t ld, bool accumulate) {
  const std::int64_t m = g.m, n = g.n;
  t_bpack.resize(std::size_t(packed_bf16_words(kc, n)));
  pack_b_bf16_strided_avx512(g.b + k0 * b.rs, b.rs, b.cs, kc, n, t_bpack.data());
  if (a.cs == 1) {  // row-major op(A): the kernel converts its rows itself
    gemm_bf16_avx512(g.a + k0, a.rs, m, kc, t_bpack.data(), n, acc, ld, nullptr, 0, nullptr, accumulate);
    return;
  }
  const std::int64_t ldw = ((kc + 1) / 2 + 15) / 16 * 16;
  t_apairs.resize(std::size_t((m + kPadRows) * ldw));
  // Rows past m: read by a partial register tile, never stored; zeros.
  std::fill(t_apairs.begin() + m * ldw, t_apairs.end(), 0u);
  bf16_pairs_strided_avx512(g.a + k0 * a.cs, a.rs, a.cs, m, kc, t_apairs.data(), ldw);
  gemm_bf16_avx512(nullptr, 0, m, kc, t_bpack.data(), n, acc, ld, t_apairs.data(), ldw, nullptr, accumulate);
}

void chunk_portable(const GemmArgs& g, Strides a, Strides b, std::int64_t k0, std::int64_t kc, float* acc,
                    std::int64_t ld, bool accumulate) {
  const std::int64_t m = g.m, n = g.n;
  t_portable_a.resize(std::size_t(m * kc));
  t_portable_b.resize(std::size_t(kc * n));
  for (std::int64_t i = 0; i < m; ++i)
    for (std::int64_t kk = 0; kk < kc; ++kk) t_portable_a[std::size_t(i * kc + kk)] = g.a[i * a.rs + (k0 + kk) * a.cs];
  for (std::int64_t kk = 0; kk < kc; ++kk)
    for (std::int64_t j = 0; j < n; ++j)
      t_portable_b[std::size_t(kk * n + j)] = bf16_round(g.b[(k0 + kk) * b.rs + j * b.cs]);
  t_portable_c.resize(std::size_t(m * n));
  gemm_bf16_portable(t_portable_a.data(), kc, m, kc, t_portable_b.data(), n, n, t_portable_c.data(), n);
  for (std::int64_t i = 0; i < m; ++i)
    for (std::int64_t j = 0; j < n; ++j) {
      const float s = t_portable_c[std::size_t(i * n + j)];
      acc[i * ld + j] = accumulate ? s + acc[i * ld + j] : s;  // the kernel's x = sum + C
    }
}
}  // namespace

void gemm_bf16_tile(const GemmArgs& g, bool hardware) {
  const std::int64_t k = g.trans_a ? g.a_rows : g.a_cols;
  const std::int64_t m = g.m, n = g.n;
  if (m == 0 || n == 0) return;
  const Strides a = op_strides(g.trans_a, g.lda), b = op_strides(g.trans_b, g.ldb);
  // alpha = 1 and beta = 0 or 1 (forward products, gradients overwritten or
  // accumulated): the chunks' sums go straight into C (beta = 0: C is only
  // written, so NaN there is ignored; beta = 1: C += each chunk in turn).
  // Otherwise into a buffer P, then C = alpha P + beta C.
  const bool direct = g.alpha == 1.0f && (g.beta == 0.0f || g.beta == 1.0f);
  float* acc = g.c;
  std::int64_t ld = g.ldc;
  if (!direct) {
    t_acc.resize(std::size_t(m * n));
    acc = t_acc.data();
    ld = n;
  }
  for (std::int64_t k0 = 0; k0 < k; k0 += kBf16Kc) {
    const std::int64_t kc = std::min(kBf16Kc, k - k0);
    const bool accumulate = k0 > 0 || (direct && g.beta == 1.0f);
    if (hardware)
      chunk_avx512(g, a, b, k0, kc, acc, ld, accumulate);
    else
      chunk_portable(g, a, b, k0, kc, acc, ld, accumulate);
  }
  if (direct) return;
  for (std::int64_t i = 0; i < m; ++i) {
    float* c = g.c + i * g.ldc;
    const float* p = acc + i * n;
    if (g.beta == 0.0f) {
      if (g.alpha == 1.0f)
        std::copy(p, p + n, c);
      else
        for (std::int64_t j = 0; j < n; ++j) c[j] = g.alpha * p[j];
    } else {
      for (std::int64_t j = 0; j < n; ++j) c[j] = g.alpha * p[j] + g.beta * c[j];
    }
  }
}

}  // namespace gatcore::cpu::detail
