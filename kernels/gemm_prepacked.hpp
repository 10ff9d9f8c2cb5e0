#pragma once
// Inference GEMM with a constant right-hand operand (a layer's weights):
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

}  // namespace gatcore::cpu
