// The Tensor type itself: allocation and alignment, views, deep copies,
// version counting, finiteness and shape checks.
#include <catch2/catch.hpp>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "gatcore/tensor.hpp"

using namespace gatcore;
using Catch::Matchers::Contains;

TEST_CASE("tensor: factories, shape, 64-byte alignment", "[tensor]") {
  for (std::int64_t r : {0, 1, 3, 17})
    for (std::int64_t c : {0, 1, 5, 33}) {
      Tensor t = Tensor::empty(r, c);
      REQUIRE(t.defined());
      REQUIRE((t.rows() == r && t.cols() == c && t.ld() == c && t.offset() == 0 && t.numel() == r * c));
      REQUIRE(t.contiguous());
      REQUIRE(t.dtype() == DType::f32);
      REQUIRE(t.device() == Device::cpu);
      REQUIRE(reinterpret_cast<std::uintptr_t>(t.data()) % 64 == 0);
      REQUIRE(t.storage()->bytes == static_cast<std::size_t>(r * c) * 4);
      Tensor z = Tensor::zeros(r, c);
      for (float v : z.to_vector()) REQUIRE(v == 0.0f);
      Tensor zi = Tensor::zeros(r, c, DType::i32);
      REQUIRE(reinterpret_cast<std::uintptr_t>(zi.data_i32()) % 64 == 0);
      for (std::int64_t i = 0; i < r * c; ++i) REQUIRE(zi.data_i32()[i] == 0);
    }
  Tensor f = Tensor::full(2, 3, 1.5f);
  for (float v : f.to_vector()) REQUIRE(v == 1.5f);
  Tensor a = Tensor::from(2, 3, {1, 2, 3, 4, 5, 6});
  REQUIRE(a.at(1, 2) == 6.0f);
  REQUIRE(a.row(1)[0] == 4.0f);
  REQUIRE(a.shape_str() == "[2, 3]");
  Tensor i = Tensor::from_i32(1, 3, {7, -8, 9});
  REQUIRE(i.dtype() == DType::i32);
  REQUIRE(i.at_i32(0, 1) == -8);
  Tensor u;
  REQUIRE_FALSE(u.defined());
  REQUIRE(u.data() == nullptr);
  REQUIRE(u.version() == 0);
  REQUIRE(u.numel() == 0);
}

namespace {
long max_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;  // KiB on Linux
}
}  // namespace

TEST_CASE("tensor: the CPU block cache reuses freed blocks and never grows the process past its high-water mark",
          "[tensor][memory]") {
  // Blocks of one size, freed, then as many of another size: a cache that kept
  // the first ones besides the second would hold both (96 + 112 MiB).
  const long before = max_rss_mib();
  auto touch = [](const Tensor& t) { t.fill_(1.0f); };
  {
    std::vector<Tensor> a;
    for (int k = 0; k < 24; ++k) touch(a.emplace_back(Tensor::empty(1024, 1024)));  // 4 MiB each
  }
  std::vector<const void*> freed;
  {
    // Past the high-water mark each new block is an old one resized (its
    // pages kept): 24 of them fault in only their 64 KiB of growth, the
    // other 4 are fresh (about 29 k faults if all 28 were; 5.6 k measured).
    const auto faults = [] {
      rusage u{};
      getrusage(RUSAGE_SELF, &u);
      return long(u.ru_minflt);
    };
    const long f0 = faults();
    std::vector<Tensor> b;
    for (int k = 0; k < 28; ++k) touch(b.emplace_back(Tensor::empty(1024, 1040)));  // 4 MiB + 64 KiB
    const long f = faults() - f0;
    INFO(f << " page faults for 28 blocks of 4 MiB + 64 KiB");
    CHECK(f < 16000);  // sanitizer builds fault their shadow pages in too
    for (std::size_t k = 0; k < b.size(); ++k)  // each block is whole and its own
      CHECK(b[k].data()[1024 * 1040 - 1] == 1.0f);
    b[3].fill_(3.0f);
    CHECK(b[4].data()[0] == 1.0f);
    for (const Tensor& t : b) freed.push_back(t.data());
  }
  // A freed block comes back for the same size (a hit, no fresh pages).
  CHECK(std::count(freed.begin(), freed.end(), Tensor::empty(1024, 1040).data()) == 1);
  const long grown = max_rss_mib() - before;
  INFO("peak grew by " << grown << " MiB");
  CHECK(grown < 150);
}

TEST_CASE("tensor: construction errors", "[tensor][errors]") {
  REQUIRE_THROWS_AS(Tensor::empty(-1, 3), InvalidArgument);
  REQUIRE_THROWS_WITH(Tensor::zeros(2, -3), Contains("negative shape"));
  // Shapes read from files: the element count or byte count would wrap.
  REQUIRE_THROWS_WITH(Tensor::empty(std::int64_t(1) << 62, 4), Contains("shape [4611686018427387904, 4] is too large"));
  REQUIRE_THROWS_WITH(Tensor::empty(std::int64_t(1) << 32, std::int64_t(1) << 32), Contains("too large"));
  REQUIRE_THROWS_WITH(Tensor::from(std::int64_t(1) << 62, 4, std::vector<float>{}), Contains("too large"));
  REQUIRE_THROWS_WITH(Tensor::from(2, 3, {1, 2}), Contains("2 values given for shape [2, 3]"));
  REQUIRE_THROWS_WITH(Tensor::from_i32(1, 2, {1, 2, 3}), Contains("3 values given for shape [1, 2]"));
  Tensor f = Tensor::zeros(2, 2), i = Tensor::zeros(2, 2, DType::i32);
  REQUIRE_THROWS_WITH(i.data(), Contains("int32"));
  REQUIRE_THROWS_WITH(f.data_i32(), Contains("float32"));
}

TEST_CASE("tensor: column and row slices are views sharing storage", "[tensor][views]") {
  Tensor t = Tensor::from(3, 4, {0, 1, 2, 3, 10, 11, 12, 13, 20, 21, 22, 23});
  Tensor c = t.cols_slice(1, 3);
  REQUIRE((c.rows() == 3 && c.cols() == 2 && c.ld() == 4 && c.offset() == 1));
  REQUIRE_FALSE(c.contiguous());
  REQUIRE(c.storage() == t.storage());
  REQUIRE(c.at(2, 1) == 22.0f);
  c.at(0, 0) = -1.0f;
  REQUIRE(t.at(0, 1) == -1.0f);
  Tensor r = t.rows_slice(1, 3);
  REQUIRE((r.rows() == 2 && r.cols() == 4 && r.ld() == 4 && r.offset() == 4));
  REQUIRE(r.contiguous());
  REQUIRE(r.at(0, 0) == 10.0f);
  Tensor rc = t.rows_slice(1, 3).cols_slice(2, 4);  // a view of a view
  REQUIRE((rc.offset() == 6 && rc.at(1, 1) == 23.0f));
  Tensor one_row = c.rows_slice(2, 3);
  REQUIRE(one_row.contiguous());  // a single row is contiguous whatever ld is
  REQUIRE(t.cols_slice(2, 2).cols() == 0);
  REQUIRE(c.to_vector() == std::vector<float>{-1, 2, 11, 12, 21, 22});
  REQUIRE_THROWS_WITH(t.cols_slice(3, 5), Contains("cols_slice(3, 5) out of range for tensor [3, 4]"));
  REQUIRE_THROWS_WITH(t.cols_slice(2, 1), Contains("cols_slice"));
  REQUIRE_THROWS_WITH(t.rows_slice(-1, 2), Contains("rows_slice(-1, 2)"));
  REQUIRE_THROWS_WITH(t.rows_slice(0, 4), Contains("rows_slice"));
  // int32 views
  Tensor i = Tensor::from_i32(2, 3, {1, 2, 3, 4, 5, 6});
  Tensor ic = i.cols_slice(1, 3);
  REQUIRE((ic.dtype() == DType::i32 && ic.at_i32(1, 0) == 5));
}

TEST_CASE("tensor: clone is a contiguous deep copy", "[tensor]") {
  Tensor t = Tensor::from(3, 4, {0, 1, 2, 3, 10, 11, 12, 13, 20, 21, 22, 23});
  Tensor v = t.cols_slice(1, 4);
  Tensor c = v.clone();
  REQUIRE((c.rows() == 3 && c.cols() == 3 && c.ld() == 3 && c.offset() == 0));
  REQUIRE(c.storage() != t.storage());
  REQUIRE(reinterpret_cast<std::uintptr_t>(c.data()) % 64 == 0);
  REQUIRE(c.to_vector() == v.to_vector());
  c.at(0, 0) = 99.0f;
  REQUIRE(t.at(0, 1) == 1.0f);
  Tensor i = Tensor::from_i32(2, 3, {1, 2, 3, 4, 5, 6}).cols_slice(1, 3);
  Tensor ic = i.clone();
  REQUIRE((ic.dtype() == DType::i32 && ic.ld() == 2 && ic.at_i32(1, 1) == 6));
  Tensor e = Tensor::empty(0, 5).clone();
  REQUIRE((e.rows() == 0 && e.cols() == 5));
}

TEST_CASE("tensor: copy_from_ honours strides and bumps the version", "[tensor][version]") {
  Tensor dst = Tensor::zeros(3, 5);
  Tensor src = Tensor::from(3, 4, {0, 1, 2, 3, 10, 11, 12, 13, 20, 21, 22, 23}).cols_slice(1, 3);
  Tensor slot = dst.cols_slice(2, 4);
  const auto v0 = dst.version();
  slot.copy_from_(src);
  REQUIRE(dst.version() == v0 + 1);
  REQUIRE(dst.to_vector() == std::vector<float>{0, 0, 1, 2, 0, 0, 0, 11, 12, 0, 0, 0, 21, 22, 0});
  REQUIRE_THROWS_WITH(slot.copy_from_(Tensor::zeros(3, 3)), Contains("copy_from_: shape [3, 3] into [3, 2]"));
  // Copying a view onto itself (or an overlapping view) is well defined.
  Tensor t = Tensor::from(2, 4, {1, 2, 3, 4, 5, 6, 7, 8});
  t.copy_from_(t);
  REQUIRE(t.to_vector() == std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8});
  t.cols_slice(0, 3).copy_from_(t.cols_slice(1, 4));
  REQUIRE(t.to_vector() == std::vector<float>{2, 3, 4, 4, 6, 7, 8, 8});
  t.cols_slice(1, 4).copy_from_(t.cols_slice(0, 3));
  REQUIRE(t.to_vector() == std::vector<float>{2, 2, 3, 4, 6, 6, 7, 8});
  Tensor rows = Tensor::from(3, 2, {1, 2, 3, 4, 5, 6});
  rows.rows_slice(1, 3).copy_from_(rows.rows_slice(0, 2));  // overlapping rows, shifted down
  REQUIRE(rows.to_vector() == std::vector<float>{1, 2, 1, 2, 3, 4});
  rows.rows_slice(0, 2).copy_from_(rows.rows_slice(1, 3));  // and up
  REQUIRE(rows.to_vector() == std::vector<float>{1, 2, 3, 4, 3, 4});
  // int32 tensors copy too; mixing dtypes is an error naming both.
  Tensor i = Tensor::zeros(1, 3, DType::i32);
  i.copy_from_(Tensor::from_i32(1, 3, {4, 5, 6}));
  REQUIRE(i.at_i32(0, 2) == 6);
  REQUIRE_THROWS_WITH(i.copy_from_(Tensor::zeros(1, 3)), Contains("copy_from_") && Contains("int32"));
}

TEST_CASE("tensor: views share the version counter; fill_ bumps it", "[tensor][version]") {
  Tensor t = Tensor::zeros(4, 4);
  Tensor v = t.cols_slice(1, 2);
  const auto v0 = t.version();
  v.fill_(3.0f);
  REQUIRE(t.version() == v0 + 1);
  REQUIRE(v.version() == t.version());
  REQUIRE(t.at(2, 1) == 3.0f);
  REQUIRE(t.at(2, 2) == 0.0f);  // only the view's columns are filled
  t.zero_();
  REQUIRE(v.version() == v0 + 2);
  t.bump_version();
  REQUIRE(t.rows_slice(0, 1).version() == v0 + 3);
  Tensor c = t.clone();
  c.fill_(1.0f);
  REQUIRE(t.version() == v0 + 3);  // a clone has its own counter
}

TEST_CASE("tensor: check_finite names what and where", "[tensor][errors]") {
  Tensor t = Tensor::zeros(3, 4);
  REQUIRE_NOTHROW(t.check_finite("features"));
  t.at(2, 1) = std::numeric_limits<float>::quiet_NaN();
  REQUIRE_THROWS_AS(t.check_finite("features"), InvalidArgument);
  REQUIRE_THROWS_WITH(t.check_finite("features"), Contains("features") && Contains("row 2, column 1"));
  t.at(2, 1) = 0.0f;
  t.at(0, 3) = INFINITY;
  REQUIRE_THROWS_WITH(t.check_finite("w"), Contains("row 0, column 3"));
  // Only the view is checked.
  REQUIRE_NOTHROW(t.cols_slice(0, 3).check_finite("view"));
  REQUIRE_THROWS_WITH(t.cols_slice(2, 4).check_finite("view"), Contains("row 0, column 1"));
}

TEST_CASE("tensor: check_shape and check_cpu_f32 messages", "[tensor][errors]") {
  Tensor t = Tensor::zeros(2, 3);
  REQUIRE_NOTHROW(check_shape(t, 2, 3, "x"));
  REQUIRE_NOTHROW(check_shape(t, -1, 3, "x"));
  REQUIRE_THROWS_WITH(check_shape(t, 1, 3, "layer: gamma"), Contains("layer: gamma: expected shape [1, 3], got [2, 3]"));
  REQUIRE_THROWS_WITH(check_shape(t, -1, 4, "x"), Contains("x: expected shape [*, 4], got [2, 3]"));
  REQUIRE_THROWS_WITH(check_shape(Tensor(), 1, 1, "w"), Contains("w: tensor is undefined"));
  REQUIRE_NOTHROW(check_cpu_f32(t, "x"));
  REQUIRE_THROWS_WITH(check_cpu_f32(Tensor::zeros(1, 1, DType::i32), "idx"), Contains("idx: expected float32"));
  REQUIRE_THROWS_WITH(check_cpu_f32(Tensor(), "y"), Contains("y: tensor is undefined"));
  REQUIRE(std::string(device_name(Device::cpu)) == "cpu");
  REQUIRE(std::string(device_name(Device::vulkan)) == "vulkan");
}
