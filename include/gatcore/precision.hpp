#pragma once
// Arithmetic precision of products: the deploy path's GEMMs (inference), and
// training's large products under a ProductPrecisionScope (below).
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

// The precision of training products on this thread, like PyTorch's autocast:
// the ops whose cost is a product of activations and weights (linear,
// linear_segment_bias, with at least 16 input columns: smaller products gain
// nothing) read it when they run forward and record it on the
// tape, so their backward products (dX = dY W^T, dW = X^T dY) use the same
// one. Everything else (losses, BatchNorm, softmax, attention, the optimiser
// and its fp32 master weights) is fp32 whatever the scope says. A backend
// without bf16 products (Backend::bf16_products(): Vulkan, a CPU without
// AVX512_BF16) runs them in fp32; models::Trainer resolves and reports that
// up front (TrainOptions::precision). fp32 outside any scope.
Precision current_product_precision();
class ProductPrecisionScope {
 public:
  explicit ProductPrecisionScope(Precision p);
  ~ProductPrecisionScope();
  ProductPrecisionScope(const ProductPrecisionScope&) = delete;
  ProductPrecisionScope& operator=(const ProductPrecisionScope&) = delete;

 private:
  Precision prev_;
};

}  // namespace gatcore
