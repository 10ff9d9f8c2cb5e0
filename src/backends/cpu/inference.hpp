#pragma once
// The CPU backend's inference entry: what the deploy path (models/deploy.cpp)
// calls for its fused frames. Everything else in src/backends/cpu/ is private
// to the CPU backend; the layers above reach the kernels only through the
// Backend (backend.hpp) or this header.
//
// Prepacked products. Inference GEMM with a constant right-hand operand (a layer's weights):
//   C = A B,  A [m, k] row-major (strided views allowed), B [k, n].
// The weights are packed once (prepack_b) into the layout the product's
// kernel reads, instead of on every call as gemm() must for operands that
// change (training). Precision::fp32 runs gemm()'s own kernel with the packing
// hoisted, so the results equal gemm(A, false, B, false, C) bitwise whenever
// gemm() does not split k (k < 2000, or C larger than one 512 x 512 tile);
// Precision::bf16 rounds both operands to bfloat16 and accumulates in fp32
// (gemm_bf16.hpp), natively on AVX512_BF16 CPUs, emulated elsewhere (same
// rounding, far slower: callers pick bf16 only when bf16_supported()).
// Threads: rows in fixed blocks over OpenMP; no result depends on the thread count.
// Not for training: there is no backward, and the deploy path is its only user.
#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#include "gatcore/activation.hpp"
#include "gatcore/graph.hpp"
#include "gatcore/precision.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// 64-byte aligned storage: the kernels read packed panels with aligned
// full-vector loads.
template <class T>
struct Aligned64 {
  using value_type = T;
  Aligned64() = default;
  template <class U>
  Aligned64(const Aligned64<U>&) {}
  T* allocate(std::size_t n) {
    void* p = std::aligned_alloc(64, (n * sizeof(T) + 63) / 64 * 64);
    if (!p) throw std::bad_alloc();
    return static_cast<T*>(p);
  }
  void deallocate(T* p, std::size_t) { std::free(p); }
  template <class U>
  bool operator==(const Aligned64<U>&) const { return true; }
};

struct PrepackedB {
  std::int64_t k = 0, n = 0;
  Precision precision = Precision::fp32;
  // fp32: B itself (gemm() runs on it when the packed AVX-512 kernel is not
  // the GEMM in use); bf16: B rounded to bf16 values (the emulated product).
  Tensor plain;
  std::vector<float, Aligned64<float>> f32;                  // fp32 panels (AVX-512 CPUs)
  std::vector<std::uint32_t, Aligned64<std::uint32_t>> bf16;  // bf16 pair panels (AVX512_BF16 CPUs)
};

// B: a [k, n] CPU f32 tensor (copied; B may change or go away afterwards).
PrepackedB prepack_b(const Tensor& B, Precision precision);
// With `sink`: each row block [i0, i0 + rows) of C is handed to sink(ctx,
// i0, rows) by the thread that computed it, as soon as it is done (still in
// cache; blocks of one call are disjoint, in any order across threads).
using RowBlockSink = void (*)(void* ctx, std::int64_t i0, std::int64_t rows);
// C [m, n] = A [m, k] times the packed B. C must not overlap A.
void gemm_prepacked(const Tensor& A, const PrepackedB& B, const Tensor& C, RowBlockSink sink = nullptr,
                    void* ctx = nullptr);

// An A operand already rounded to bf16, as pair words: row i's columns
// (2p, 2p + 1) in words[i * ld + p] (low half first; an odd column count's
// last high half zero). For operands a caller reuses across products: the
// deploy path keeps such a copy of each DenseNet buffer, converting each
// block's new columns once, where every later block's product would
// otherwise convert (and read in fp32) the whole prefix again.
struct Bf16Rows {
  const std::uint32_t* words = nullptr;
  std::int64_t rows = 0, cols = 0, ld = 0;  // ld in words
};
// A's rows as bf16 pair words into dst (row i at dst + i * ld). Bitwise the
// rounding gemm_prepacked applies to a float A.
void bf16_pairs(const Tensor& A, std::uint32_t* dst, std::int64_t ld);
// C = A B for a bf16 packed B: bitwise gemm_prepacked on the float A these
// words came from. The storage must hold A.rows + 24 rows of ld words (the
// kernel's last register tile reads rows it does not store). `sink`: as
// for the fp32 A.
void gemm_prepacked(const Bf16Rows& A, const PrepackedB& B, const Tensor& C, RowBlockSink sink = nullptr,
                    void* ctx = nullptr);
// A dense layer on bf16 rows, its output as bf16 rows for the next product:
// dst = bf16_pairs(act(A B + bias)) (act: identity or tanh), bitwise
// gemm_prepacked, add_row_bias, activation_forward and bf16_pairs, but the
// sums are finished in the product's registers: no fp32 [m, n] written and
// read back three times. bias: [1, n] or undefined. C [m, n]: scratch (the
// partial sums of k beyond one k block; contents unspecified afterwards).
// dst: rows of ld >= ceil(n / 2) words (+ 24 rows, as for the Bf16Rows that
// reads them). AVX512_BF16 CPUs only (throws otherwise).
void gemm_prepacked_bias_act_bf16(const Bf16Rows& A, const PrepackedB& B, const Tensor& bias, Activation act,
                                  const Tensor& C, std::uint32_t* dst, std::int64_t ld);

// Fused GAT epilogues. The end of a GAT block on the deploy path (models/deploy.cpp), in one pass
// over the block's attention output `att` [n, kf] and self stream `self`
// [n, S] (S = 0: undefined), W = kf + S columns:
//   y = affine(tanhshrink([att | self + self_b]))
// affine: BatchNorm's prepared eval map ((x - mean) * scale + shift, as
// batchnorm_affine_forward; undefined mean = none). The composition it
// replaces (copying both streams into one [n, W] tensor, add_row_bias on the
// self columns, activation_forward tanhshrink, batchnorm_affine_forward, and
// on the bf16 path bf16_pairs) reads and writes the block's output four or
// five times; on a 10k-vertex frame those passes were a quarter of the bf16
// frame's time and a sixth of the fp32 one's. Same arithmetic as the
// composition at the AVX-512 level (tested bitwise).
//
// Two destinations (gat_epilogue_impl.inc holds the shared arithmetic):
// - fp32 (gat_epilogue.cpp): y into `out` [n, W] (any row stride; must not
//   overlap the inputs). AVX-512 only: gat_epilogue_supported() says whether
//   the active SIMD level is AVX-512; below it the deploy path runs the
//   composition (its kernels have AVX2 and scalar versions).
// - bf16 (gat_epilogue_bf16.cpp): y only as bf16 pair words (row i at dst +
//   i * ld, ceil(W/2) words: bf16_pairs' layout), the form every later
//   product of the block's DenseNet buffer reads. AVX512_BF16 CPUs only
//   (bf16_supported(); the deploy path uses bf16 nowhere else).
// Both throw when called where they cannot run.

bool gat_epilogue_supported();  // simd_level() is AVX-512

void gat_epilogue(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                  const Tensor& scale, const Tensor& shift, const Tensor& out);
void gat_epilogue_bf16(const Tensor& att, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                       const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld);

// The block's attention and the epilogue in one pass: att =
// gat_fused_additive_forward(g, z, el, er, slope) row by row
// (gat_fused_additive_forward_rows), each chunk of rows finished while still
// in L1, so neither att [n, kf] nor (for 8 heads of 8) the attention weights
// go through memory. Bitwise gat_fused_additive_forward followed by the
// epilogue (tested). alpha [E, H]: scratch (see
// gat_fused_additive_forward_rows).
void gat_attention_epilogue(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                            const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                            const Tensor& scale, const Tensor& shift, const Tensor& out);
void gat_attention_epilogue_bf16(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er, float slope,
                                 const Tensor& alpha, const Tensor& self, const Tensor& self_b, const Tensor& mean,
                                 const Tensor& scale, const Tensor& shift, std::uint32_t* dst, std::int64_t ld);

// Row-block kernels a product's sink runs on the rows it just finished.
// Rows [r0, r1) only, on the calling thread (no parallel region): for a
// caller already inside one, e.g. after each row block of z's product while
// the block is in cache (models/deploy.cpp). The same values as the whole call.
void attention_projection_forward_rows(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                       const Tensor& er, std::int64_t r0, std::int64_t r1);
// Evaluation with the per-column affine map prepared once (deploy time, no
// allocation per call): y = (x - mean) * scale + shift, where
// scale = gamma / sqrt(running_var + eps) computed in double and rounded to
// float (batchnorm_eval_scale). Gives exactly batchnorm_eval_forward's values.
void batchnorm_affine_forward(const Tensor& x, const Tensor& mean, const Tensor& scale, const Tensor& shift,
                              const Tensor& y);
// The eval forward's per-column scale, written into `scale` [1, C].
void batchnorm_eval_scale(const Tensor& gamma, const Tensor& running_var, float eps, const Tensor& scale);
// Rows [r0, r1) of a dense layer's finish: lin += bias (bias [1, C] or
// undefined), then y = f(lin) (f identity: y undefined, or lin itself, or
// a copy). Bitwise add_row_bias then activation_forward on those rows, but
// serial and on a few rows: a product's row-block sink runs it inside the
// product's parallel region while the block is in cache (gemm_prepacked).
// f: identity, tanh or tanhshrink (throws otherwise).
void bias_activation_rows(const Tensor& bias, Activation f, const Tensor& lin, const Tensor& y, std::int64_t r0,
                          std::int64_t r1);

}  // namespace gatcore::cpu
