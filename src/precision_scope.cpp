// ProductPrecisionScope (precision.hpp): a thread-local setting, as the
// batch split is (batch_split.cpp).
#include "gatcore/precision.hpp"

namespace gatcore {
namespace {
thread_local Precision g_product_precision = Precision::fp32;
}

Precision current_product_precision() { return g_product_precision; }

ProductPrecisionScope::ProductPrecisionScope(Precision p) : prev_(g_product_precision) { g_product_precision = p; }
ProductPrecisionScope::~ProductPrecisionScope() { g_product_precision = prev_; }

}  // namespace gatcore
