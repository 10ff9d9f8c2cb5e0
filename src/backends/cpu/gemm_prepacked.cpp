// inference.hpp: packing once, dispatch per ISA, and the row-block threading.
#include "src/backends/cpu/inference.hpp"

#include <algorithm>

#include "gatcore/error.hpp"
#include "src/backends/cpu/gemm.hpp"
#include "src/backends/cpu/gemm_bf16.hpp"
#include "src/backends/cpu/gemm_impl.hpp"
#include "src/backends/cpu/nn_detail.hpp"
#include "src/backends/cpu/simd.hpp"

namespace gatcore {

const char* precision_name(Precision p) { return p == Precision::bf16 ? "bf16" : "fp32"; }

Precision parse_precision(const std::string& s, const char* what) {
  if (s == "fp32") return Precision::fp32;
  if (s == "bf16") return Precision::bf16;
  throw InvalidArgument(std::string(what) + ": '" + s + "' is not a precision (fp32, bf16)");
}

bool bf16_supported() { return cpu::simd_level() == cpu::SimdLevel::avx512 && cpu::detail::cpu_has_avx512_bf16(); }

namespace cpu {

namespace {
// Rows per parallel task: whole register tiles of both kernels (12 / 24 rows),
// small enough that 2k-vertex meshes still give each thread several tasks.
constexpr std::int64_t kRowBlock = 120;
// Below this many flops one thread does the product (as gemm()).
constexpr double kParallelMinFlops = 4.0e6;
}  // namespace

PrepackedB prepack_b(const Tensor& B, Precision precision) {
  check_cpu_f32(B, "prepack_b: B");
  PrepackedB p;
  p.k = B.rows();
  p.n = B.cols();
  p.precision = precision;
  p.plain = B.clone();
  if (precision == Precision::fp32) {
#if defined(__x86_64__) && defined(__GNUC__)
    if (detected_simd_level() == SimdLevel::avx512 && p.k > 0 && p.n > 0) {
      p.f32.resize(std::size_t(detail::prepacked_size_avx512(p.k, p.n)));
      detail::GemmArgs g{nullptr, 0, p.k, 1, false, p.plain.data(), p.k, p.n, std::max<std::int64_t>(p.plain.ld(), 1),
                         false, nullptr, 0, p.n, 0, 1.0f, 0.0f};
      detail::prepack_b_avx512(g, p.f32.data());
    }
#endif
    return p;
  }
  for (std::int64_t r = 0; r < p.k; ++r) {
    float* row = p.plain.row(r);
    for (std::int64_t j = 0; j < p.n; ++j) row[j] = bf16_round(row[j]);
  }
  if (detail::cpu_has_avx512_bf16() && p.k > 0 && p.n > 0) {
    p.bf16.resize(std::size_t(detail::packed_bf16_words(p.k, p.n)));
    detail::pack_b_bf16(p.plain.data(), p.plain.ld(), p.k, p.n, p.bf16.data());
  }
  return p;
}

namespace {
// f(i0, rows) over fixed row blocks, spread over the OpenMP threads.
template <class F>
void for_row_blocks(std::int64_t m, std::int64_t n, std::int64_t k, F&& f) {
  const std::int64_t blocks = (m + kRowBlock - 1) / kRowBlock;
  const double flops = 2.0 * double(m) * double(n) * double(k);
#pragma omp parallel for schedule(static) if (blocks > 1 && flops >= kParallelMinFlops)
  for (std::int64_t blk = 0; blk < blocks; ++blk) f(blk * kRowBlock, std::min(kRowBlock, m - blk * kRowBlock));
}
// The sink over every row block, after a product that did not hand them out.
void sink_all_blocks(std::int64_t m, std::int64_t n, std::int64_t k, RowBlockSink sink, void* ctx) {
  if (sink) for_row_blocks(m, n, k, [&](std::int64_t i0, std::int64_t rows) { sink(ctx, i0, rows); });
}
}  // namespace

void bf16_pairs(const Tensor& A, std::uint32_t* dst, std::int64_t ld) {
  check_cpu_f32(A, "bf16_pairs: A");
  const std::int64_t k = A.cols(), words = (k + 1) / 2;
  GATCORE_CHECK(ld >= words, "bf16_pairs: ld ", ld, " is below the ", words, " words of a row");
  const bool hw = bf16_supported();
  for_row_blocks(A.rows(), 8, k, [&](std::int64_t i0, std::int64_t rows) {
    for (std::int64_t i = i0; i < i0 + rows; ++i) {
      const float* a = A.row(i);
      std::uint32_t* d = dst + i * ld;
#if defined(__x86_64__) && defined(__GNUC__)
      if (hw) {
        detail::bf16_pairs_avx512(a, k, d);
        continue;
      }
#endif
      for (std::int64_t p = 0; p < words; ++p)
        d[p] = bf16_bits(a[2 * p]) | (2 * p + 1 < k ? std::uint32_t(bf16_bits(a[2 * p + 1])) << 16 : 0u);
    }
  });
}

namespace {
// Shape checks of a product on bf16 rows (fn names the entry point).
void check_bf16_rows(const char* fn, const char* fn_c, const Bf16Rows& A, const PrepackedB& B, const Tensor& C) {
  check_cpu_f32(C, fn_c);
  const std::int64_t m = A.rows, k = A.cols, n = B.n;
  GATCORE_CHECK(B.precision == Precision::bf16, fn, ": bf16 rows need a B packed in bf16");
  GATCORE_CHECK(k == B.k, fn, ": A [", m, ", ", k, "] has ", k, " columns, the packed B has ", B.k, " rows");
  GATCORE_CHECK(C.rows() == m && C.cols() == n, fn, ": C: expected shape [", m, ", ", n, "], got ", C.shape_str());
  GATCORE_CHECK(A.words && A.ld >= (k + 1) / 2, fn, ": bf16 rows: null, or ld ", A.ld, " below ", (k + 1) / 2,
                " words");
}
}  // namespace

void gemm_prepacked_bias_act_bf16(const Bf16Rows& A, const PrepackedB& B, const Tensor& bias, Activation act,
                                  const Tensor& C, std::uint32_t* dst, std::int64_t ld) {
  static const char* fn = "gemm_prepacked_bias_act_bf16";
  check_bf16_rows(fn, "gemm_prepacked_bias_act_bf16: C", A, B, C);
  const std::int64_t m = A.rows, k = A.cols, n = B.n;
  GATCORE_CHECK(act == Activation::identity || act == Activation::tanh, fn, ": activation ", activation_name(act),
                " (identity or tanh only)");
  if (bias.defined()) detail::check_arg(bias, 1, n, "gemm_prepacked_bias_act_bf16: bias");
  GATCORE_CHECK(dst && ld >= (n + 1) / 2, fn, ": destination null, or ld ", ld, " below ", (n + 1) / 2, " words");
  GATCORE_CHECK(!B.bf16.empty() && bf16_supported(), fn, ": needs a CPU with AVX512_BF16");
  GATCORE_CHECK(k > 0, fn, ": k = 0");
  if (m == 0 || n == 0) return;
#if defined(__x86_64__) && defined(__GNUC__)
  float* c = C.data();
  const std::int64_t ldc = C.ld();
  const detail::Bf16Epilogue epi{bias.defined() ? bias.data() : nullptr, act == Activation::tanh, dst, ld};
  for_row_blocks(m, n, k, [&](std::int64_t i0, std::int64_t rows) {
    detail::Bf16Epilogue e = epi;
    e.words = dst + i0 * ld;
    detail::gemm_bf16_avx512(nullptr, 0, rows, k, B.bf16.data(), n, c + i0 * ldc, ldc, A.words + i0 * A.ld, A.ld, &e);
  });
#endif
}

void gemm_prepacked(const Bf16Rows& A, const PrepackedB& B, const Tensor& C, RowBlockSink sink, void* ctx) {
  check_bf16_rows("gemm_prepacked", "gemm_prepacked: C", A, B, C);
  const std::int64_t m = A.rows, k = A.cols, n = B.n;
  if (m == 0 || n == 0) return;
  if (k == 0) {
    for (std::int64_t r = 0; r < m; ++r) std::fill(C.row(r), C.row(r) + n, 0.0f);
    sink_all_blocks(m, n, k, sink, ctx);
    return;
  }
  float* c = C.data();
  const std::int64_t ldc = C.ld();
  const bool hw = !B.bf16.empty() && bf16_supported();
  for_row_blocks(m, n, k, [&](std::int64_t i0, std::int64_t rows) {
#if defined(__x86_64__) && defined(__GNUC__)
    if (hw) {
      detail::gemm_bf16_avx512(nullptr, 0, rows, k, B.bf16.data(), n, c + i0 * ldc, ldc, A.words + i0 * A.ld, A.ld);
    } else
#endif
    {
      std::vector<float> a(static_cast<std::size_t>(k));  // the portable path: values back to floats
      for (std::int64_t i = i0; i < i0 + rows; ++i) {
        const std::uint32_t* w = A.words + i * A.ld;
        for (std::int64_t kk = 0; kk < k; ++kk)
          a[std::size_t(kk)] = bf16_to_float(std::uint16_t(kk % 2 ? w[kk / 2] >> 16 : w[kk / 2] & 0xFFFFu));
        detail::gemm_bf16_portable(a.data(), k, 1, k, B.plain.data(), B.plain.ld(), n, c + i * ldc, ldc);
      }
    }
    if (sink) sink(ctx, i0, rows);
  });
}

void gemm_prepacked(const Tensor& A, const PrepackedB& B, const Tensor& C, RowBlockSink sink, void* ctx) {
  check_cpu_f32(A, "gemm_prepacked: A");
  check_cpu_f32(C, "gemm_prepacked: C");
  const std::int64_t m = A.rows(), k = A.cols(), n = B.n;
  GATCORE_CHECK(k == B.k, "gemm_prepacked: A ", A.shape_str(), " has ", k, " columns, the packed B has ", B.k, " rows");
  GATCORE_CHECK(C.rows() == m && C.cols() == n, "gemm_prepacked: C: expected shape [", m, ", ", n, "], got ",
                C.shape_str());
  GATCORE_CHECK(!detail::views_overlap(C, A), "gemm_prepacked: C ", C.shape_str(), " overlaps A ", A.shape_str(),
                " (the output must not alias an input)");
  if (m == 0 || n == 0) return;
  if (k == 0) {
    for (std::int64_t r = 0; r < m; ++r) std::fill(C.row(r), C.row(r) + n, 0.0f);
    sink_all_blocks(m, n, k, sink, ctx);
    return;
  }
  const float* a = A.data();
  float* c = C.data();
  const std::int64_t lda = std::max<std::int64_t>(A.ld(), 1), ldc = C.ld();
  enum class Path { gemm, f32, bf16, bf16_portable } path = Path::gemm;
  if (B.precision == Precision::fp32)
    path = !B.f32.empty() && detail::gemm_uses_packed_avx512() ? Path::f32 : Path::gemm;
  else
    path = !B.bf16.empty() && bf16_supported() ? Path::bf16 : Path::bf16_portable;
  if (path == Path::gemm) {  // the same kernel choice as gemm() makes, on the plain copy
    gemm(A, false, B.plain, false, C, 1.0f, 0.0f);
    sink_all_blocks(m, n, k, sink, ctx);
    return;
  }
  for_row_blocks(m, n, k, [&](std::int64_t i0, std::int64_t rows) {
    switch (path) {
#if defined(__x86_64__) && defined(__GNUC__)
      case Path::f32: {
        detail::GemmArgs g{a + i0 * lda, rows, k,   lda,  false, B.plain.data(), k,    n,
                           B.plain.ld(), false, c + i0 * ldc, rows, n, ldc, 1.0f, 0.0f};
        detail::gemm_prepacked_avx512(g, B.f32.data());
        break;
      }
      case Path::bf16: detail::gemm_bf16_avx512(a + i0 * lda, lda, rows, k, B.bf16.data(), n, c + i0 * ldc, ldc); break;
#endif
      default:
        detail::gemm_bf16_portable(a + i0 * lda, lda, rows, k, B.plain.data(), B.plain.ld(), n, c + i0 * ldc, ldc);
        break;
    }
    if (sink) sink(ctx, i0, rows);
  });
}

}  // namespace cpu
}  // namespace gatcore
