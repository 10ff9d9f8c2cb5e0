#pragma once
// The CPU backend's entry for the rest of the library: the Backend the
// registry (src/backend.cpp) gives for Device::cpu. Its kernels stay private
// to this folder.
#include "gatcore/backend.hpp"

namespace gatcore {

Backend& cpu_backend();

}  // namespace gatcore
