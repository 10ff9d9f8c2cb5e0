#pragma once
// Arithmetic precision of inference products (the deploy path's GEMMs; never
// training, which is fp32 throughout).
//   fp32: the training kernels' arithmetic (the runtime's results are then
//         bitwise those of models::predict / gat deform).
//   bf16: the products' operands rounded to bfloat16 (8-bit mantissa, round to
//         nearest even), products accumulated in fp32, on CPUs with AVX512_BF16
//         (twice the fp32 multiply-add rate there). Everything outside the
//         products (attention, activations, normalisation) stays fp32.
#include <string>

namespace gatcore {

enum class Precision { fp32, bf16 };

const char* precision_name(Precision p);  // "fp32" / "bf16"
// "fp32" / "bf16"; anything else throws InvalidArgument naming `what` and the value.
Precision parse_precision(const std::string& s, const char* what = "precision");
// Whether this CPU runs bf16 products natively (AVX-512 F/BW/VL and
// AVX512_BF16, and GATCORE_SIMD does not force a lower level).
bool bf16_supported();

}  // namespace gatcore
