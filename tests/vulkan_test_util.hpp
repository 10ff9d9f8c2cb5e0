#pragma once
// Shared by tests/test_vulkan_*.cpp: brings the Vulkan backend up (or reports
// visibly why the test is skipped) and compares device results with the CPU.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "gatcore/backend.hpp"
#include "gatcore/vulkan.hpp"

namespace vkt {

// True when the Vulkan backend is up. Otherwise prints the reason once and the
// calling test returns (counted as passed, reported as SKIPPED on stderr).
// The tests allow CPU-type devices (GATCORE_VK_ALLOW_CPU=1 unless set), so
// lavapipe serves where no GPU exists; GATCORE_VK_DEVICE picks one explicitly.
inline bool ready() {
  static int state = -1;
  static std::string reason;
  if (state < 0) {
    setenv("GATCORE_VK_ALLOW_CPU", "1", 0);
    try {
      gatcore::vulkan::init();
      state = 1;
    } catch (const std::exception& e) {
      state = 0;
      reason = e.what();
    }
  }
  if (!state) {
    std::fprintf(stderr, "SKIPPED (no Vulkan device): %s\n", reason.c_str());
    WARN("SKIPPED: no Vulkan device: " << reason);
  }
  return state == 1;
}

// Under the test hook GATCORE_VK_MAX_BINDING_BYTES (ctest's *_smallbind
// variants) the binding range is tiny, so the parity tests run the
// large-operand paths. A test makes a LargePaths at its start and calls
// require() at its end: with the hook, its ops must have gone through them
// (device-address shaders or row-chunked elementwise dispatches); without it,
// through neither (every operand of the small parity tests fits a binding).
struct LargePaths {
  gatcore::vulkan::Stats before = gatcore::vulkan::stats();
  void require() const {
    const char* cap = std::getenv("GATCORE_VK_MAX_BINDING_BYTES");
    const auto now = gatcore::vulkan::stats();
    const std::uint64_t bda = now.bda_dispatches - before.bda_dispatches;
    const std::uint64_t chunked = now.chunked_dispatches - before.chunked_dispatches;
    INFO("device-address dispatches " << bda << ", chunked dispatches " << chunked
                                      << " (GATCORE_VK_MAX_BINDING_BYTES=" << (cap ? cap : "unset") << ")");
    if (cap && *cap) REQUIRE(bda + chunked > 0);
    else REQUIRE(bda + chunked == 0);
  }
};

inline gatcore::Tensor V(const gatcore::Tensor& t) { return gatcore::to(t, gatcore::Device::vulkan); }
inline gatcore::Tensor H(const gatcore::Tensor& t) { return gatcore::to(t, gatcore::Device::cpu); }

// |vk - cpu| <= atol + rtol |cpu| for every entry (vk may be a device tensor).
inline void require_close(const gatcore::Tensor& cpu, const gatcore::Tensor& vk_in, float rtol = 1e-4f,
                          float atol = 1e-5f, const char* what = "") {
  gatcore::Tensor vk = H(vk_in);
  REQUIRE(cpu.rows() == vk.rows());
  REQUIRE(cpu.cols() == vk.cols());
  double worst = 0;
  std::int64_t wr = 0, wc = 0;
  for (std::int64_t r = 0; r < cpu.rows(); ++r)
    for (std::int64_t c = 0; c < cpu.cols(); ++c) {
      const double a = cpu.at(r, c), b = vk.at(r, c);
      const double excess = std::abs(a - b) - (atol + rtol * std::abs(a));
      if (excess > worst || std::isnan(b) != std::isnan(a)) {
        worst = std::isnan(b) != std::isnan(a) ? 1e30 : excess;
        wr = r;
        wc = c;
      }
    }
  INFO(what << ": worst entry (" << wr << ", " << wc << "): cpu " << (cpu.numel() ? cpu.at(wr, wc) : 0.f)
            << " vulkan " << (vk.numel() ? vk.at(wr, wc) : 0.f));
  REQUIRE(worst <= 0.0);
}

}  // namespace vkt
