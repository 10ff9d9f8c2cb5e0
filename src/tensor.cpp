#include "gatcore/tensor.hpp"

#include "gatcore/activation.hpp"
#include "gatcore/backend.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sys/mman.h>
#include <iterator>
#include <limits>
#include <list>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

namespace gatcore {

const char* activation_name(Activation a) {
  switch (a) {
    case Activation::identity: return "identity";
    case Activation::tanh: return "tanh";
    case Activation::tanhshrink: return "tanhshrink";
    case Activation::leaky_relu: return "leaky_relu";
    case Activation::relu: return "relu";
  }
  return "?";
}

const char* device_name(Device d) {
  switch (d) {
    case Device::cpu: return "cpu";
    case Device::vulkan: return "vulkan";
  }
  return "?";
}

Storage::~Storage() {
  if (release) release(*this);
}

namespace {
// Large CPU blocks are kept for reuse instead of going back to the C library.
// Why: a training step allocates and frees the same few hundred large
// tensors every step; glibc serves them with fresh mmap()s, so every step
// paid a page fault and a kernel page clear per 4 KiB (about a fifth of a
// DenseGATs step under perf). Blocks are matched by (rounded) size,
// which is what a repeated step asks for; the cache holds at most
// GATCORE_CPU_CACHE MiB (default 1024; 0 turns it off) so idle memory stays
// bounded.
// The cache never makes the process bigger than the most the program has
// had in use at once (of these blocks): a miss lets go of cached blocks, the
// longest cached first, while blocks in use + cached would pass that
// high-water mark. Without this, blocks of the sizes a step frees late (its
// forward activations, freed in backward) sat in the cache while the sizes
// backward asks for were allocated besides them: NeuroSkinning's training
// step peaked 262 MiB (27 %) above what it uses. A request may also take a
// cached block up to 1/8 larger than it asks for (the smallest such): near
// sizes then share blocks, and fewer misses fault fresh pages in (steady
// NeuroSkinning step: 93 k page faults instead of 144 k; the cache without
// a bound had almost none, at +262 MiB; bench/RESULTS.md). Such a block
// goes back to the cache at its own size.
constexpr std::size_t kBlockCacheMin = std::size_t(256) << 10;  // smaller blocks: malloc is fast enough
constexpr std::size_t kBlockGranule = std::size_t(64) << 10;    // rounding, so near sizes share blocks

// The blocks the cache manages are mapped and unmapped directly: a block it
// lets go of goes back to the system at once (glibc keeps freed blocks below
// its mmap threshold, which grows up to 32 MiB, in its heap).
void* map_block(std::size_t bytes) {
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  return p == MAP_FAILED ? nullptr : p;
}
void unmap_block(void* p, std::size_t bytes) { munmap(p, bytes); }

class BlockCache {
 public:
  static BlockCache& get() {
    static BlockCache* c = new BlockCache;  // never destroyed: storages may outlive static destruction
    return *c;
  }
  bool enabled() const { return max_ > 0; }
  // A cached block of `bytes` to bytes + bytes/8, or nullptr (the caller
  // allocates `bytes` afresh) after letting go of what would take the
  // process past its high-water mark.
  void* take(std::size_t bytes) {
    std::vector<Block> evicted;
    void* hit = nullptr;
    {
      std::lock_guard<std::mutex> lock(mu_);
      auto it = by_size_.lower_bound(bytes);
      if (it != by_size_.end() && it->first <= bytes + bytes / 8) {
        hit = it->second->ptr;
        if (it->first != bytes) larger_.emplace(hit, it->first);
        cached_ -= it->first;
        in_use_ += it->first;
        by_age_.erase(it->second);
        by_size_.erase(it);
        return hit;
      }
      in_use_ += bytes;
      high_water_ = std::max(high_water_, in_use_);
      while (in_use_ + cached_ > high_water_ && !by_age_.empty()) {
        evicted.push_back(by_age_.front());
        cached_ -= by_age_.front().bytes;
        erase_from_size_index(by_age_.begin());
        by_age_.pop_front();
      }
    }
    if (evicted.empty()) return nullptr;
    // One of the blocks let go of becomes the new one, resized in place of
    // an unmap and a fresh map: its pages stay (up to the smaller size), so
    // they are neither faulted in nor cleared again. The one that keeps the
    // most pages.
    auto keep = std::max_element(evicted.begin(), evicted.end(), [&](const Block& a, const Block& b) {
      return std::min(a.bytes, bytes) < std::min(b.bytes, bytes);
    });
    const Block k = *keep;
    evicted.erase(keep);
    for (const Block& b : evicted) unmap_block(b.ptr, b.bytes);
    // (Never the asked-for size: a block of it would have been a hit.)
    void* p = mremap(k.ptr, k.bytes, bytes, MREMAP_MAYMOVE);
    if (p != MAP_FAILED) return p;
    unmap_block(k.ptr, k.bytes);
    return nullptr;
  }
  // Keeps the block (asked for as `bytes`) if there is room, else frees it.
  void give(void* p, std::size_t bytes) {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (auto l = larger_.find(p); l != larger_.end()) {
        bytes = l->second;
        larger_.erase(l);
      }
      in_use_ -= bytes;
      if (cached_ + bytes <= max_) {
        by_age_.push_back(Block{p, bytes});
        by_size_.emplace(bytes, std::prev(by_age_.end()));
        cached_ += bytes;
        return;
      }
    }
    unmap_block(p, bytes);
  }
  // A block that failed to allocate after take() counted it.
  void untake(std::size_t bytes) {
    std::lock_guard<std::mutex> lock(mu_);
    in_use_ -= bytes;
  }

 private:
  struct Block {
    void* ptr;
    std::size_t bytes;
  };
  using AgeIt = std::list<Block>::iterator;
  BlockCache() {
    const char* e = std::getenv("GATCORE_CPU_CACHE");
    max_ = std::size_t(e && *e ? std::strtoull(e, nullptr, 10) : 1024) << 20;
  }
  void erase_from_size_index(AgeIt a) {
    auto [lo, hi] = by_size_.equal_range(a->bytes);
    for (auto it = lo; it != hi; ++it)
      if (it->second == a) {
        by_size_.erase(it);
        return;
      }
  }
  std::mutex mu_;
  std::list<Block> by_age_;                 // oldest first
  std::multimap<std::size_t, AgeIt> by_size_;
  std::unordered_map<void*, std::size_t> larger_;  // blocks in use that are larger than asked for: their size
  std::size_t cached_ = 0;
  std::size_t in_use_ = 0, high_water_ = 0;  // bytes of the blocks handed out (by take())
  std::size_t max_ = 0;
};

std::size_t block_bytes(std::size_t bytes) {
  // 64-byte alignment (one cache line / one AVX-512 register); aligned_alloc
  // needs a multiple of the alignment.
  std::size_t rounded = (bytes + 63) / 64 * 64;
  if (rounded == 0) rounded = 64;
  if (rounded >= kBlockCacheMin) rounded = (rounded + kBlockGranule - 1) / kBlockGranule * kBlockGranule;
  return rounded;
}
}  // namespace

static void release_cpu(Storage& s) {
  const std::size_t rounded = block_bytes(s.bytes);
  if (rounded >= kBlockCacheMin && BlockCache::get().enabled())
    BlockCache::get().give(s.host, rounded);
  else if (rounded >= kBlockCacheMin)
    unmap_block(s.host, rounded);
  else
    std::free(s.host);
}

std::shared_ptr<Storage> Storage::allocate_cpu(std::size_t bytes) {
  auto s = std::make_shared<Storage>();
  const std::size_t rounded = block_bytes(bytes);
  const bool cached = rounded >= kBlockCacheMin && BlockCache::get().enabled();
  if (cached) s->host = BlockCache::get().take(rounded);
  if (!s->host) s->host = rounded >= kBlockCacheMin ? map_block(rounded) : std::aligned_alloc(64, rounded);
  if (!s->host) {
    if (cached) BlockCache::get().untake(rounded);
    throw Error(detail::cat("gatcore: out of memory allocating ", bytes, " bytes"));
  }
  s->bytes = bytes;
  s->device = Device::cpu;
  s->release = release_cpu;
  return s;
}

Tensor Tensor::wrap(std::shared_ptr<Storage> s, DType dt, std::int64_t offset, std::int64_t rows,
                    std::int64_t cols, std::int64_t ld) {
  Tensor t;
  t.storage_ = std::move(s);
  t.dtype_ = dt;
  t.offset_ = offset;
  t.rows_ = rows;
  t.cols_ = cols;
  t.ld_ = ld;
  return t;
}

namespace {
// Bytes of a [rows, cols] tensor of 4-byte elements; shapes come from files
// (checkpoints, caches), so the product is checked before it is formed: it
// must fit in an int64 (numel()) and, times 4, in a size_t.
std::size_t tensor_bytes(std::int64_t rows, std::int64_t cols, const char* what) {
  GATCORE_CHECK(rows >= 0 && cols >= 0, what, ": negative shape [", rows, ", ", cols, "]");
  constexpr std::int64_t kMaxElems = std::numeric_limits<std::int64_t>::max() / 8;  // bytes fit with room to round
  GATCORE_CHECK(cols == 0 || rows <= kMaxElems / cols, what, ": shape [", rows, ", ", cols,
                "] is too large (more than ", kMaxElems, " elements)");
  return static_cast<std::size_t>(rows * cols) * 4;
}
}  // namespace

Tensor Tensor::empty(std::int64_t rows, std::int64_t cols, DType dt) {
  auto s = Storage::allocate_cpu(tensor_bytes(rows, cols, "Tensor::empty"));
  return wrap(std::move(s), dt, 0, rows, cols, cols);
}

Tensor Tensor::zeros(std::int64_t rows, std::int64_t cols, DType dt) {
  Tensor t = empty(rows, cols, dt);
  if (rows * cols != 0) std::memset(t.storage_->host, 0, static_cast<std::size_t>(rows * cols) * 4);
  return t;
}

Tensor Tensor::full(std::int64_t rows, std::int64_t cols, float value) {
  Tensor t = empty(rows, cols);
  float* p = t.data();
  for (std::int64_t i = 0; i < rows * cols; ++i) p[i] = value;
  return t;
}

Tensor Tensor::from(std::int64_t rows, std::int64_t cols, const std::vector<float>& values) {
  GATCORE_CHECK(values.size() * 4 == tensor_bytes(rows, cols, "Tensor::from"), "Tensor::from: ",
                values.size(), " values given for shape [", rows, ", ", cols, "]");
  Tensor t = empty(rows, cols);
  if (!values.empty()) std::memcpy(t.data(), values.data(), values.size() * 4);
  return t;
}

Tensor Tensor::from(std::int64_t rows, std::int64_t cols, std::initializer_list<float> values) {
  return from(rows, cols, std::vector<float>(values));
}

Tensor Tensor::from_i32(std::int64_t rows, std::int64_t cols, const std::vector<std::int32_t>& values) {
  GATCORE_CHECK(values.size() * 4 == tensor_bytes(rows, cols, "Tensor::from_i32"), "Tensor::from_i32: ",
                values.size(), " values given for shape [", rows, ", ", cols, "]");
  Tensor t = empty(rows, cols, DType::i32);
  if (!values.empty()) std::memcpy(t.data_i32(), values.data(), values.size() * 4);
  return t;
}

std::string Tensor::shape_str() const { return detail::cat("[", rows_, ", ", cols_, "]"); }

float* Tensor::data() const {
  if (!storage_) return nullptr;
  GATCORE_CHECK(dtype_ == DType::f32, "tensor ", shape_str(), " is int32, not float32");
  GATCORE_CHECK(storage_->host != nullptr, "tensor ", shape_str(), " lives on device ",
                device_name(storage_->device), " and is not host-addressable; move it with to(Device::cpu)");
  return static_cast<float*>(storage_->host) + offset_;
}

std::int32_t* Tensor::data_i32() const {
  if (!storage_) return nullptr;
  GATCORE_CHECK(dtype_ == DType::i32, "tensor ", shape_str(), " is float32, not int32");
  GATCORE_CHECK(storage_->host != nullptr, "tensor ", shape_str(), " lives on device ",
                device_name(storage_->device), " and is not host-addressable; move it with to(Device::cpu)");
  return static_cast<std::int32_t*>(storage_->host) + offset_;
}

Tensor Tensor::cols_slice(std::int64_t c0, std::int64_t c1) const {
  GATCORE_CHECK(0 <= c0 && c0 <= c1 && c1 <= cols_, "cols_slice(", c0, ", ", c1,
                ") out of range for tensor ", shape_str());
  return wrap(storage_, dtype_, offset_ + c0, rows_, c1 - c0, ld_);
}

Tensor Tensor::rows_slice(std::int64_t r0, std::int64_t r1) const {
  GATCORE_CHECK(0 <= r0 && r0 <= r1 && r1 <= rows_, "rows_slice(", r0, ", ", r1,
                ") out of range for tensor ", shape_str());
  return wrap(storage_, dtype_, offset_ + r0 * ld_, r1 - r0, cols_, ld_);
}

Tensor Tensor::clone() const {
  if (storage_ && storage_->device != Device::cpu) {
    // A device tensor: a copy on the same device, by its backend.
    Backend& be = backend(storage_->device);
    Tensor t = be.empty(rows_, cols_, dtype_);
    if (rows_ * cols_ != 0) be.copy(*this, t);
    return t;
  }
  Tensor t = empty(rows_, cols_, dtype_);
  const char* src = static_cast<const char*>(storage_ ? storage_->host : nullptr);
  GATCORE_CHECK(rows_ * cols_ == 0 || src, "clone: tensor on ", device_name(device()), " is not host-addressable");
  for (std::int64_t r = 0; r < rows_; ++r)
    std::memcpy(static_cast<char*>(t.storage_->host) + r * cols_ * 4, src + (offset_ + r * ld_) * 4,
                static_cast<std::size_t>(cols_) * 4);
  return t;
}

std::vector<float> Tensor::to_vector() const {
  std::vector<float> v(static_cast<std::size_t>(numel()));
  for (std::int64_t r = 0; r < rows_; ++r)
    for (std::int64_t c = 0; c < cols_; ++c) v[r * cols_ + c] = at(r, c);
  return v;
}

void Tensor::fill_(float v) const {
  float* p = data();
  for (std::int64_t r = 0; r < rows_; ++r)
    for (std::int64_t c = 0; c < cols_; ++c) p[r * ld_ + c] = v;
  bump_version();
}

void Tensor::copy_from_(const Tensor& src) const {
  GATCORE_CHECK(same_shape(src), "copy_from_: shape ", src.shape_str(), " into ", shape_str());
  GATCORE_CHECK(dtype_ == src.dtype_, "copy_from_: ", src.dtype_ == DType::i32 ? "int32" : "float32", " tensor ",
                src.shape_str(), " into a ", dtype_ == DType::i32 ? "int32" : "float32", " tensor");
  // Both dtypes are 4 bytes; data() / data_i32() check host addressability.
  char* d = reinterpret_cast<char*>(dtype_ == DType::i32 ? static_cast<void*>(data_i32()) : data());
  const char* s =
      reinterpret_cast<const char*>(dtype_ == DType::i32 ? static_cast<void*>(src.data_i32()) : src.data());
  const std::size_t row_bytes = static_cast<std::size_t>(cols_) * 4;
  // memmove per row, and rows in the order that never reads a row already
  // overwritten, so overlapping views of one storage copy correctly.
  if (row_bytes != 0) {
    if (d > s)
      for (std::int64_t r = rows_ - 1; r >= 0; --r) std::memmove(d + r * ld_ * 4, s + r * src.ld_ * 4, row_bytes);
    else if (d < s)
      for (std::int64_t r = 0; r < rows_; ++r) std::memmove(d + r * ld_ * 4, s + r * src.ld_ * 4, row_bytes);
  }
  bump_version();
}

void Tensor::check_finite(const char* what) const {
  const float* p = data();
  for (std::int64_t r = 0; r < rows_; ++r)
    for (std::int64_t c = 0; c < cols_; ++c)
      if (!std::isfinite(p[r * ld_ + c]))
        throw InvalidArgument(detail::cat(what, ": non-finite value ", p[r * ld_ + c], " at row ", r,
                                          ", column ", c));
}

void check_shape(const Tensor& t, std::int64_t rows, std::int64_t cols, const char* what) {
  GATCORE_CHECK(t.defined(), what, ": tensor is undefined");
  GATCORE_CHECK((rows < 0 || t.rows() == rows) && (cols < 0 || t.cols() == cols), what, ": expected shape [",
                rows < 0 ? std::string("*") : std::to_string(rows), ", ",
                cols < 0 ? std::string("*") : std::to_string(cols), "], got ", t.shape_str());
}

void check_cpu_f32(const Tensor& t, const char* what) {
  GATCORE_CHECK(t.defined(), what, ": tensor is undefined");
  GATCORE_CHECK(t.device() == Device::cpu, what, ": tensor lives on ", device_name(t.device()),
                ", this kernel runs on the CPU");
  GATCORE_CHECK(t.dtype() == DType::f32, what, ": expected float32");
}

}  // namespace gatcore
