// The Vulkan runtime: command batching (one submission per host read), a
// tensor larger than maxStorageBufferRange (128 MiB on lavapipe) through
// elementwise kernels, clear errors for a missing device, out-of-memory and
// host access to device memory.
#include "gatcore/graph.hpp"
#include "gradcheck.hpp"
#include "vulkan_test_util.hpp"

using namespace gatcore;
using vkt::H;
using vkt::V;

TEST_CASE("vulkan: ops are batched into one submission per host read", "[vulkan]") {
  if (!vkt::ready()) return;
  Backend& be = backend(Device::vulkan);
  std::mt19937 rng(5);
  Tensor a = gradcheck::random_tensor(64, 32, rng);
  Tensor x = V(a), y = be.zeros(64, 32, DType::f32), s = be.empty(1, 1, DType::f32);
  vulkan::sync();
  const auto before = vulkan::stats();
  for (int k = 0; k < 50; ++k) be.axpy(0.5f, x, y);
  be.sum_all(y, s);
  const auto mid = vulkan::stats();
  REQUIRE(mid.submits == before.submits);  // nothing submitted while recording
  REQUIRE(mid.dispatches == before.dispatches + 51);
  const float total = H(s).at(0, 0);  // the read submits once
  REQUIRE(vulkan::stats().submits == before.submits + 1);
  double expect = 0;
  for (float v : a.to_vector()) expect += 25.0 * v;
  REQUIRE(total == Approx(expect).epsilon(1e-4).margin(1e-3));
  // A batch is cut (submitted) after 8192 dispatches without a host read.
  vulkan::sync();
  const auto s0 = vulkan::stats();
  for (int k = 0; k < 8200; ++k) be.axpy(1e-3f, x, y);
  REQUIRE(vulkan::stats().submits == s0.submits + 1);
  vulkan::sync();
  REQUIRE(vulkan::stats().submits == s0.submits + 2);
  // clone() of a device tensor stays on the device (also of a strided view).
  Tensor c = y.cols_slice(3, 9).clone();
  REQUIRE(c.device() == Device::vulkan);
  REQUIRE(c.contiguous());
  vkt::require_close(H(y).cols_slice(3, 9).clone(), c, 0, 0, "clone");
  // Device tensors are not host-addressable.
  REQUIRE_THROWS_WITH(y.data(), Catch::Contains("not host-addressable"));
}

TEST_CASE("vulkan: a tensor larger than maxStorageBufferRange goes through", "[vulkan]") {
  if (!vkt::ready()) return;
  Backend& be = backend(Device::vulkan);
  // 9000 x 4000 floats = 144 MB > 128 MiB: the elementwise ops split it into
  // row chunks bound at offsets.
  const std::int64_t rows = 9000, cols = 4000;
  Tensor a = be.empty(rows, cols, DType::f32), b = be.empty(rows, cols, DType::f32);
  be.fill(a, 1.5f);
  be.fill(b, -2.0f);
  be.axpby(2.0f, a, 0.25f, b, b);  // b = 3 - 0.5 = 2.5
  be.axpy(1.0f, a, b);             // b = 4
  Tensor h = H(b);
  REQUIRE(h.at(0, 0) == 4.0f);
  REQUIRE(h.at(rows / 2, 17) == 4.0f);
  REQUIRE(h.at(rows - 1, cols - 1) == 4.0f);
  std::int64_t bad = 0;
  const float* p = h.data();
  for (std::int64_t i = 0; i < rows * cols; ++i) bad += p[i] != 4.0f;
  REQUIRE(bad == 0);
  // A view deep into the buffer (offset beyond 128 MiB) works in any kernel.
  Tensor tail = b.rows_slice(rows - 3, rows).cols_slice(5, 9);
  Tensor s = be.empty(1, 1, DType::f32);
  be.sum_all(tail, s);
  REQUIRE(H(s).at(0, 0) == 48.0f);
}

TEST_CASE("vulkan: clear errors for a missing device and out of memory", "[vulkan]") {
  if (!vkt::ready()) return;
  REQUIRE_THROWS_WITH(vulkan::init("no-such-vulkan-device"), Catch::Contains("no Vulkan device matches"));
  REQUIRE_THROWS_WITH(vulkan::init("99"), Catch::Contains("out of range"));
  // Selecting the current device again, by index or by name, is a no-op.
  const auto cur = vulkan::current_device();
  REQUIRE_NOTHROW(vulkan::init(std::to_string(cur.index)));
  if (cur.index == 0) REQUIRE_NOTHROW(vulkan::init(cur.name));
  REQUIRE(vulkan::select(std::to_string(cur.index)) == Device::vulkan);
  Backend& be = backend(Device::vulkan);
  REQUIRE_THROWS_WITH(be.empty(std::int64_t{1} << 21, std::int64_t{1} << 20, DType::f32),
                      Catch::Contains("out of device memory"));
  // The backend still works afterwards.
  Tensor t = be.zeros(3, 3, DType::f32);
  be.fill(t, 1.f);
  REQUIRE(H(t).at(2, 2) == 1.f);
}

// Run by ctest with VK_ICD_FILENAMES pointing nowhere (test
// vulkan_no_device): no device at all.
TEST_CASE("vulkan: no device gives a clear error, and 'auto' falls back to the CPU", "[.nodevice]") {
  REQUIRE(vulkan::list_devices().empty());
  REQUIRE_THROWS_WITH(vulkan::init(""), Catch::Contains("vulkan:"));
  REQUIRE_THROWS_WITH(vulkan::select("gpu"), Catch::Contains("vulkan:"));
  REQUIRE(vulkan::select("auto") == Device::cpu);
  REQUIRE_FALSE(has_backend(Device::vulkan));
}
