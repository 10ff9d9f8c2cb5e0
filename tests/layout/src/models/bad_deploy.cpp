// Fixture for layout_dependency_direction_catches: models/ reaches the CPU
// kernels only through the backend entries, never a private kernel header.
#include "src/backends/cpu/gemm.hpp"
