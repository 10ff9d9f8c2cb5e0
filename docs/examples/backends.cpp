// docs/library.md, "Backends": ops run on the backend of their tensors'
// device. Moves a product to Vulkan when a GPU is there (or lavapipe with
// GATCORE_VK_ALLOW_CPU=1), else stays on the CPU, and checks the result
// against the CPU's. Built and run by the ctest docs_example_backends.
#include <cmath>
#include <cstdio>

#include "gatcore/backend.hpp"
#include "gatcore/ops.hpp"
#include "gatcore/vulkan.hpp"

int main() {
  using namespace gatcore;
  Tensor a = Tensor::from(2, 3, {1, 2, 3, 4, 5, 6});
  Tensor b = Tensor::from(3, 2, {1, 0, 0, 1, 1, 1});
  Tensor on_cpu = matmul(Var(a), Var(b)).value();

  // "auto": a Vulkan device when one is usable, else Device::cpu (said on stderr).
  Device d = vulkan::compiled() ? vulkan::select("auto") : Device::cpu;
  Var c = matmul(Var(to(a, d)), Var(to(b, d)));  // runs on d's backend
  Tensor back = to(c.value(), Device::cpu);       // reading submits the recorded work
  std::printf("device %s: [%g %g; %g %g]\n", device_name(d), back.at(0, 0), back.at(0, 1), back.at(1, 0),
              back.at(1, 1));
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      if (std::fabs(back.at(i, j) - on_cpu.at(i, j)) > 1e-5f) return 1;
  return on_cpu.at(0, 0) == 4 && on_cpu.at(1, 1) == 11 ? 0 : 1;
}
