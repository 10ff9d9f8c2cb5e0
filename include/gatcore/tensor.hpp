#pragma once
// A 2-D row-major float32 (or int32) tensor: [rows, cols] with a row stride
// (ld >= cols) so a column slice is a view, not a copy. DenseNet concatenation
// relies on that: every block writes straight into its slice of one buffer.
//
// Storage is 64-byte aligned and reference counted; views share it, and share
// its version counter (bumped by every in-place write) so autodiff can detect
// a saved tensor that was modified before backward().
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "gatcore/error.hpp"

namespace gatcore {

enum class Device : std::uint8_t { cpu = 0, vulkan = 1 };
enum class DType : std::uint8_t { f32 = 0, i32 = 1 };

const char* device_name(Device d);

// Raw memory owned by one backend. `host` is a CPU pointer when the memory is
// host-addressable (always for Device::cpu); `handle` is backend-private
// (e.g. a Vulkan buffer) and is released by `release`.
struct Storage {
  void* host = nullptr;
  std::size_t bytes = 0;
  Device device = Device::cpu;
  void* handle = nullptr;
  void (*release)(Storage&) = nullptr;
  std::uint64_t version = 0;

  Storage() = default;
  Storage(const Storage&) = delete;
  Storage& operator=(const Storage&) = delete;
  ~Storage();

  static std::shared_ptr<Storage> allocate_cpu(std::size_t bytes);
};

class Tensor {
 public:
  Tensor() = default;

  // Uninitialised / zero-filled / filled tensors on the CPU.
  static Tensor empty(std::int64_t rows, std::int64_t cols, DType dt = DType::f32);
  static Tensor zeros(std::int64_t rows, std::int64_t cols, DType dt = DType::f32);
  static Tensor full(std::int64_t rows, std::int64_t cols, float value);
  // Copies `values` (row-major, rows*cols of them).
  static Tensor from(std::int64_t rows, std::int64_t cols, const std::vector<float>& values);
  static Tensor from(std::int64_t rows, std::int64_t cols, std::initializer_list<float> values);
  static Tensor from_i32(std::int64_t rows, std::int64_t cols, const std::vector<std::int32_t>& values);
  // Wraps an existing storage (used by backends).
  static Tensor wrap(std::shared_ptr<Storage> s, DType dt, std::int64_t offset, std::int64_t rows,
                     std::int64_t cols, std::int64_t ld);

  bool defined() const { return storage_ != nullptr; }
  std::int64_t rows() const { return rows_; }
  std::int64_t cols() const { return cols_; }
  std::int64_t ld() const { return ld_; }  // elements between consecutive rows
  std::int64_t offset() const { return offset_; }  // elements from the storage start
  std::int64_t numel() const { return rows_ * cols_; }
  bool contiguous() const { return ld_ == cols_ || rows_ <= 1; }
  bool same_shape(const Tensor& o) const { return rows_ == o.rows_ && cols_ == o.cols_; }
  DType dtype() const { return dtype_; }
  Device device() const { return storage_ ? storage_->device : Device::cpu; }
  const std::shared_ptr<Storage>& storage() const { return storage_; }
  std::string shape_str() const;

  // Host pointers (the tensor must be host-addressable). The handle semantics
  // are those of a shared pointer: constness of the handle is not constness
  // of the data.
  float* data() const;
  std::int32_t* data_i32() const;
  float* row(std::int64_t r) const { return data() + r * ld_; }
  float& at(std::int64_t r, std::int64_t c) const { return data()[r * ld_ + c]; }
  std::int32_t& at_i32(std::int64_t r, std::int64_t c) const { return data_i32()[r * ld_ + c]; }

  // Views sharing storage (and version counter).
  Tensor cols_slice(std::int64_t c0, std::int64_t c1) const;
  Tensor rows_slice(std::int64_t r0, std::int64_t r1) const;

  // Deep copies.
  Tensor clone() const;  // contiguous copy, same device
  std::vector<float> to_vector() const;

  // In-place writes through these bump the version.
  void fill_(float v) const;
  void zero_() const { fill_(0.0f); }
  void copy_from_(const Tensor& src) const;

  std::uint64_t version() const { return storage_ ? storage_->version : 0; }
  void bump_version() const {
    if (storage_) ++storage_->version;
  }

  // Throws InvalidArgument naming `what` and the first non-finite entry.
  void check_finite(const char* what) const;

 private:
  std::shared_ptr<Storage> storage_;
  std::int64_t offset_ = 0, rows_ = 0, cols_ = 0, ld_ = 0;
  DType dtype_ = DType::f32;
};

// Shape checks with messages naming the argument.
void check_shape(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* what);
void check_cpu_f32(const Tensor& t, const char* what);

}  // namespace gatcore
