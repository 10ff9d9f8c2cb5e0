#pragma once
namespace gatcore {
// Pointwise nonlinearities shared by the kernels, the backends and the layers.
enum class Activation { identity, tanh, tanhshrink, leaky_relu, relu };
const char* activation_name(Activation a);
}  // namespace gatcore
