// Backend for Device::vulkan: every entry records compute dispatches of the
// shaders/ of the same name into the current command buffer (stream.cpp).
// Every entry has a shader; none falls back to the CPU (device tensors are
// not host-addressable, so a CPU kernel could not even read them).
//
// Tensor views are bound at their (alignment-rounded) byte offset with the
// residual element offset and row stride in push constants, so a binding
// covers only the span a view touches.
//
// Large operands (a span past maxStorageBufferRange, 128 MiB on lavapipe, or
// past GATCORE_VK_MAX_BINDING_BYTES): elementwise ops split rows into chunks
// whose spans fit, so they need nothing from the device. Every other op (graph
// kernels gather arbitrary neighbour rows, GEMM walks all of K, reductions and
// BatchNorm walk all rows) runs its shader's _bda variant instead (stream.cpp):
// the same source built with -DGATCORE_BDA, reaching each operand through its
// 64-bit device address, so no window has to hold the whole operand and the
// dispatch shape stays that of the small case. Chosen over several descriptor
// windows per operand, which the gathers could only use by branching per
// access, and over chunking output rows, which cannot split the gathered side.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "gatcore/backend.hpp"
#include "src/backends/vulkan/runtime.hpp"

namespace gatcore::vk {

namespace {

void check_vk(const Tensor& t, const char* what) {
  GATCORE_CHECK(t.defined(), what, ": tensor is undefined");
  GATCORE_CHECK(t.device() == Device::vulkan, what, ": tensor lives on ", device_name(t.device()),
                ", this op runs on vulkan");
}

std::uint32_t u32(std::int64_t v, const char* what) {
  GATCORE_CHECK(v >= 0 && v < (std::int64_t{1} << 31), "vulkan: ", what, " = ", v, " exceeds 2^31");
  return static_cast<std::uint32_t>(v);
}

// Collects bindings and push-constant words in shader declaration order.
struct Launch {
  std::vector<Binding> bindings;
  std::vector<std::uint32_t> push;
  Launch& u(std::int64_t v) {
    push.push_back(u32(v, "size"));
    return *this;
  }
  Launch& f(float v) {
    push.push_back(std::bit_cast<std::uint32_t>(v));
    return *this;
  }
  // A view: binding at the aligned byte offset, (residual offset, ld) pushed.
  Launch& t(const Tensor& x, bool write, const char* what) {
    check_vk(x, what);
    const Context& c = ctx();
    Buffer* b = buffer_of(*x.storage());
    const std::uint64_t start = static_cast<std::uint64_t>(x.offset()) * 4;
    const std::uint64_t base = start - start % c.storage_align;
    const std::uint64_t span =
        x.rows() == 0 || x.cols() == 0 ? 4 : static_cast<std::uint64_t>((x.rows() - 1) * x.ld() + x.cols()) * 4;
    std::uint64_t range = start - base + span;
    range = std::min<std::uint64_t>((range + 3) / 4 * 4, b->size - base);
    // Shaders index 32-bit (SPIR-V access chains take signed indices).
    GATCORE_CHECK(range / 4 < (std::uint64_t{1} << 31), "vulkan: ", what, " ", x.shape_str(), " spans ", range,
                  " bytes; shaders index at most 2^31 elements per operand");
    bindings.push_back({b->buffer, base, range, write, what, b});
    push.push_back(static_cast<std::uint32_t>((start - base) / 4));
    push.push_back(u32(x.ld(), "row stride"));
    return *this;
  }
  // An optional view: undefined binds a dummy and pushes (0, 0).
  Launch& opt(const Tensor& x, bool write, const char* what) {
    if (x.defined()) return t(x, write, what);
    bindings.push_back({});
    push.push_back(0);
    push.push_back(0);
    return *this;
  }
  // A whole device array (graph arrays).
  Launch& raw(const Storage& s, const char* what = "graph array") {
    Buffer* b = buffer_of(s);
    bindings.push_back(
        {b->buffer, 0, std::min<std::uint64_t>(std::max<std::uint64_t>(s.bytes, 4), b->size), false, what, b});
    GATCORE_CHECK(bindings.back().range / 4 < (std::uint64_t{1} << 31), "vulkan: ", what, " of ", s.bytes,
                  " bytes: shaders index at most 2^31 elements per operand");
    return *this;
  }
  void run(const char* shader, std::uint64_t groups) {
    if (groups == 0) return;
    const std::uint32_t gx = static_cast<std::uint32_t>(std::min<std::uint64_t>(groups, 65535));
    const std::uint32_t gy = static_cast<std::uint32_t>((groups + gx - 1) / gx);
    dispatch(shader, bindings, push.data(), static_cast<std::uint32_t>(push.size() * 4), gx, gy, 1);
  }
  // One invocation per item.
  void per_invocation(const char* shader, std::uint64_t items) {
    const std::uint32_t wg = pipeline(shader).wg_size;
    run(shader, (items + wg - 1) / wg);
  }
  // One subgroup per item.
  void per_subgroup(const char* shader, std::uint64_t items) {
    const std::uint32_t per_group = pipeline(shader).wg_size / ctx().subgroup_size;
    run(shader, (items + per_group - 1) / per_group);
  }
};

struct EwArg {
  Tensor t;
  bool write;
  bool rowwise = true;  // sliced by row chunks (false: bound whole, e.g. a bias row)
  const char* what = "tensor";
};

// An elementwise shader over [rows, cols] with header (rows, cols), one view per
// argument, then `extra` words; rows are split into chunks whose spans fit a
// binding (ctx().max_binding). Where not even one row fits, the whole range
// goes to the _bda variant in one dispatch.
void elementwise(const char* shader, std::int64_t rows, std::int64_t cols, const std::vector<EwArg>& args,
                 const std::vector<std::uint32_t>& extra) {
  if (rows == 0 || cols == 0) return;
  const Context& c = ctx();
  std::int64_t chunk = rows;
  bool by_address = false;
  for (const EwArg& a : args) {
    if (!a.rowwise || !a.t.defined()) continue;
    const std::int64_t ld = std::max<std::int64_t>(a.t.ld(), 1);
    const std::int64_t budget = static_cast<std::int64_t>(c.max_binding - c.storage_align) / 4 - cols;
    if (budget < 0) {
      GATCORE_CHECK(c.bda, "vulkan: ", shader, ": a single row of ", a.what, " ", a.t.shape_str(),
                    " exceeds the device's binding range (", c.max_binding, " bytes) and ", c.info.name,
                    " has no bufferDeviceAddress");
      by_address = true;
    }
    chunk = std::min(chunk, std::max<std::int64_t>(budget, 0) / ld + 1);
  }
  if (by_address) chunk = rows;
  chunk = std::min<std::int64_t>(chunk, std::max<std::int64_t>(1, ((std::int64_t{1} << 31) - 1) / cols));
  for (std::int64_t r0 = 0; r0 < rows; r0 += chunk) {
    const std::int64_t r1 = std::min(rows, r0 + chunk);
    Launch l;
    l.u(r1 - r0).u(cols);
    for (const EwArg& a : args) {
      if (!a.t.defined()) l.opt(a.t, a.write, a.what);
      else l.t(a.rowwise ? a.t.rows_slice(r0, r1) : a.t, a.write, a.what);
    }
    l.push.insert(l.push.end(), extra.begin(), extra.end());
    l.per_invocation(shader, static_cast<std::uint64_t>((r1 - r0) * cols));
    if (chunk < rows) ++stats_ref().chunked_dispatches;
  }
}

std::uint32_t fw(float v) { return std::bit_cast<std::uint32_t>(v); }

void same(const Tensor& a, const Tensor& b, const char* op, const char* an, const char* bn) {
  check_vk(a, an);
  check_vk(b, bn);
  GATCORE_CHECK(a.same_shape(b), op, ": ", an, " ", a.shape_str(), " and ", bn, " ", b.shape_str(),
                " must have the same shape");
}

class VulkanBackend final : public Backend {
 public:
  Device device() const override { return Device::vulkan; }

  Tensor empty(std::int64_t r, std::int64_t c, DType dt) override {
    GATCORE_CHECK(r >= 0 && c >= 0, "vulkan empty: negative shape [", r, ", ", c, "]");
    auto s = make_storage(static_cast<std::uint64_t>(r * c) * 4);
    return Tensor::wrap(std::move(s), dt, 0, r, c, c);
  }
  Tensor zeros(std::int64_t r, std::int64_t c, DType dt) override {
    Tensor t = empty(r, c, dt);
    fill(t, 0.0f);
    return t;
  }
  void fill(const Tensor& y, float v) override { elementwise("fill", y.rows(), y.cols(), {{y, true}}, {fw(v)}); }
  void copy(const Tensor& src, const Tensor& dst) override {
    same(src, dst, "copy", "src", "dst");
    elementwise("copy", src.rows(), src.cols(), {{src, false}, {dst, true}}, {});
  }
  Tensor from_host(const Tensor& host) override {
    GATCORE_CHECK(host.defined() && host.device() == Device::cpu, "vulkan from_host: expects a CPU tensor");
    const Tensor h = host.contiguous() && host.offset() == 0 ? host : host.clone();
    const std::uint64_t bytes = static_cast<std::uint64_t>(h.numel()) * 4;
    auto s = upload(h.storage()->host, bytes);
    return Tensor::wrap(std::move(s), h.dtype(), 0, h.rows(), h.cols(), h.cols());
  }
  Tensor to_host(const Tensor& t) override {
    check_vk(t, "to_host");
    Tensor out = Tensor::empty(t.rows(), t.cols(), t.dtype());
    if (t.numel() == 0) return out;
    const std::uint64_t span = static_cast<std::uint64_t>((t.rows() - 1) * t.ld() + t.cols());
    if (t.contiguous()) {
      download(*t.storage(), static_cast<std::uint64_t>(t.offset()) * 4, span * 4, out.storage()->host);
    } else {
      std::vector<float> tmp(span);
      download(*t.storage(), static_cast<std::uint64_t>(t.offset()) * 4, span * 4, tmp.data());
      char* o = static_cast<char*>(out.storage()->host);
      for (std::int64_t r = 0; r < t.rows(); ++r)
        std::memcpy(o + r * t.cols() * 4, tmp.data() + r * t.ld(), static_cast<std::size_t>(t.cols()) * 4);
    }
    return out;
  }

  void gemm(const Tensor& A, bool ta, const Tensor& B, bool tb, const Tensor& C, float alpha, float beta) override {
    check_vk(A, "gemm: A");
    check_vk(B, "gemm: B");
    check_vk(C, "gemm: C");
    const std::int64_t M = ta ? A.cols() : A.rows(), K = ta ? A.rows() : A.cols();
    const std::int64_t K2 = tb ? B.cols() : B.rows(), N = tb ? B.rows() : B.cols();
    GATCORE_CHECK(K == K2 && C.rows() == M && C.cols() == N, "gemm: op(A) [", M, ", ", K, "] x op(B) [", K2, ", ",
                  N, "] into C ", C.shape_str());
    if (M == 0 || N == 0) return;
    // The shader walks K in 16-deep tiles, one loop iteration each; lavapipe
    // ends an invocation's loops after 65535 iterations in total (see
    // STRIDED_FOR in shaders/common.glsl), so K is split into slices of at
    // most kMaxK, each accumulated into C (beta applies to the first).
    constexpr std::int64_t kMaxK = 16 * 32768;
    for (std::int64_t k0 = 0; k0 < std::max<std::int64_t>(K, 1); k0 += kMaxK) {
      const std::int64_t k1 = std::min(K, k0 + kMaxK);
      const Tensor a = K <= kMaxK ? A : ta ? A.rows_slice(k0, k1) : A.cols_slice(k0, k1);
      const Tensor b = K <= kMaxK ? B : tb ? B.cols_slice(k0, k1) : B.rows_slice(k0, k1);
      Launch l;
      l.u(M).u(N).u(k1 - k0).t(a, false, "gemm: A").t(b, false, "gemm: B").t(C, true, "gemm: C");
      l.u(ta).u(tb).f(alpha).f(k0 == 0 ? beta : 1.0f);
      const std::uint32_t gx = static_cast<std::uint32_t>((N + 63) / 64), gy = static_cast<std::uint32_t>((M + 63) / 64);
      dispatch("gemm", l.bindings, l.push.data(), static_cast<std::uint32_t>(l.push.size() * 4), gx, gy, 1);
    }
  }
  void add_row_bias(const Tensor& bias, const Tensor& y) override {
    check_vk(bias, "add_row_bias: bias");
    check_shape(bias, 1, y.cols(), "add_row_bias: bias");
    elementwise("add_row_bias", y.rows(), y.cols(), {{bias, false, false, "bias"}, {y, true}}, {});
  }
  void column_sums_accumulate(const Tensor& d_y, const Tensor& d_bias) override {
    check_vk(d_y, "column_sums_accumulate: d_y");
    check_vk(d_bias, "column_sums_accumulate: d_bias");
    check_shape(d_bias, 1, d_y.cols(), "column_sums_accumulate: d_bias");
    Launch l;
    l.u(d_y.rows()).u(d_y.cols()).t(d_y, false, "d_y").t(d_bias, true, "d_bias");
    l.run("column_sums_accumulate", static_cast<std::uint64_t>(d_y.cols()));
  }
  void axpby(float a, const Tensor& x, float b, const Tensor& y, const Tensor& out) override {
    same(x, out, "axpby", "a", "y");
    same(y, out, "axpby", "b", "y");
    elementwise("axpby", out.rows(), out.cols(), {{x, false}, {y, false}, {out, true}}, {fw(a), fw(b)});
  }
  void axpy(float a, const Tensor& x, const Tensor& y) override {
    same(x, y, "axpy", "x", "y");
    elementwise("axpy", y.rows(), y.cols(), {{x, false}, {y, true}}, {fw(a)});
  }
  void mul(const Tensor& a, const Tensor& b, const Tensor& y) override {
    same(a, y, "mul", "a", "y");
    same(b, y, "mul", "b", "y");
    elementwise("mul", y.rows(), y.cols(), {{a, false}, {b, false}, {y, true}}, {});
  }
  void mul_accumulate(const Tensor& b, const Tensor& d_y, const Tensor& d_a) override {
    if (!d_a.defined()) return;
    same(b, d_a, "mul_accumulate", "b", "d_a");
    same(d_y, d_a, "mul_accumulate", "d_y", "d_a");
    elementwise("mul_accumulate", d_a.rows(), d_a.cols(), {{b, false}, {d_y, false}, {d_a, true}}, {});
  }
  void activation_forward(Activation f, const Tensor& x, const Tensor& y, float slope) override {
    same(x, y, "activation_forward", "x", "y");
    elementwise("activation_forward", x.rows(), x.cols(), {{x, false}, {y, true}},
                {static_cast<std::uint32_t>(f), fw(slope)});
  }
  void activation_backward(Activation f, const Tensor& x, const Tensor& y, const Tensor& d_y, const Tensor& d_x,
                           float slope, bool accumulate) override {
    check_vk(d_y, "activation_backward: d_y");
    GATCORE_CHECK(f == Activation::identity || x.defined() || (y.defined() && f != Activation::tanhshrink),
                  "activation_backward(", activation_name(f), "): x: tensor is undefined");
    if (!d_x.defined()) return;
    same(d_y, d_x, "activation_backward", "d_y", "d_x");
    if (x.defined()) same(x, d_x, "activation_backward", "x", "d_x");
    if (y.defined()) same(y, d_x, "activation_backward", "y", "d_x");
    const bool use_y = y.defined() && (f == Activation::tanh || !x.defined());
    // The shader accumulates; a fresh d_x is cleared first (on the GPU the
    // fill is one more dispatch, not a serial pass).
    if (!accumulate) fill(d_x, 0.0f);
    elementwise("activation_backward", d_x.rows(), d_x.cols(),
                {{x, false}, {use_y ? y : Tensor(), false}, {d_y, false}, {d_x, true}},
                {static_cast<std::uint32_t>(f), fw(slope), x.defined() ? 1u : 0u, use_y ? 1u : 0u});
  }
  void row_softmax_forward(const Tensor& x, const Tensor& mask, const Tensor& y) override {
    same(x, y, "row_softmax_forward", "x", "y");
    if (mask.defined()) check_shape(mask, 1, x.cols(), "row_softmax_forward: mask");
    Launch l;
    l.u(x.rows()).u(x.cols()).t(x, false, "x").opt(mask, false, "mask").t(y, true, "y").u(mask.defined());
    l.per_subgroup("row_softmax_forward", static_cast<std::uint64_t>(x.rows()));
  }
  void row_softmax_backward(const Tensor& y, const Tensor& d_y, const Tensor& d_x) override {
    if (!d_x.defined()) return;
    same(y, d_x, "row_softmax_backward", "y", "d_x");
    same(d_y, d_x, "row_softmax_backward", "d_y", "d_x");
    Launch l;
    l.u(y.rows()).u(y.cols()).t(y, false, "y").t(d_y, false, "d_y").t(d_x, true, "d_x");
    l.per_subgroup("row_softmax_backward", static_cast<std::uint64_t>(y.rows()));
  }
  void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                               const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd,
                               const Tensor& running_mean, const Tensor& running_var) override {
    same(x, y, "batchnorm_train_forward", "x", "y");
    GATCORE_CHECK(x.rows() >= 2, "batchnorm_train_forward: needs at least 2 rows, got ", x.shape_str());
    GATCORE_CHECK(eps >= 0.0f && std::isfinite(eps), "batchnorm_train_forward: eps must be finite and >= 0");
    batchnorm_forward(0, x, gamma, beta, eps, momentum, y, save_mean, save_invstd, running_mean, running_var);
  }
  void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& rm,
                              const Tensor& rv, float eps, const Tensor& y) override {
    same(x, y, "batchnorm_eval_forward", "x", "y");
    check_shape(rm, 1, x.cols(), "batchnorm_eval_forward: running_mean");
    check_shape(rv, 1, x.cols(), "batchnorm_eval_forward: running_var");
    batchnorm_forward(1, x, gamma, beta, eps, 0.0f, y, Tensor(), Tensor(), rm, rv);
  }
  void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                                const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                                const Tensor& d_gamma, const Tensor& d_beta, bool accumulate_dx) override {
    check_shape(save_mean, 1, x.cols(), "batchnorm_train_backward: save_mean");
    check_shape(save_invstd, 1, x.cols(), "batchnorm_train_backward: save_invstd");
    if (!accumulate_dx && d_x.defined()) fill(d_x, 0.0f);  // the shader accumulates
    batchnorm_backward(0, x, gamma, save_mean, save_invstd, 0.0f, d_y, d_x, d_gamma, d_beta);
  }
  void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& rm, const Tensor& rv, float eps,
                               const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma,
                               const Tensor& d_beta) override {
    check_shape(rm, 1, x.cols(), "batchnorm_eval_backward: running_mean");
    check_shape(rv, 1, x.cols(), "batchnorm_eval_backward: running_var");
    batchnorm_backward(1, x, gamma, rm, rv, eps, d_y, d_x, d_gamma, d_beta);
  }

  void sum_all(const Tensor& x, const Tensor& out) override {
    check_vk(x, "sum_all: x");
    check_shape(out, 1, 1, "sum_all: out");
    Launch l;
    l.u(x.rows()).u(x.cols()).t(x, false, "x").t(out, true, "out");
    l.run("sum_all", 1);
  }
  void add_scalar_accumulate(const Tensor& s, float scale, const Tensor& d_x) override {
    check_shape(s, 1, 1, "add_scalar_accumulate: s");
    check_vk(d_x, "add_scalar_accumulate: d_x");
    elementwise("add_scalar_accumulate", d_x.rows(), d_x.cols(), {{s, false, false, "s"}, {d_x, true}}, {fw(scale)});
  }
  void mse_forward(const Tensor& pred, const Tensor& target, const Tensor& out) override {
    same(pred, target, "mse_forward", "pred", "target");
    check_shape(out, 1, 1, "mse_forward: out");
    Launch l;
    l.u(pred.rows()).u(pred.cols()).t(pred, false, "pred").t(target, false, "target").t(out, true, "out");
    l.run("mse_forward", 1);
  }
  void mse_backward(const Tensor& pred, const Tensor& target, const Tensor& d_out, const Tensor& d_pred) override {
    if (!d_pred.defined()) return;
    same(pred, target, "mse_backward", "pred", "target");
    same(pred, d_pred, "mse_backward", "pred", "d_pred");
    check_shape(d_out, 1, 1, "mse_backward: d_out");
    const float inv_n = pred.numel() ? 1.0f / static_cast<float>(pred.numel()) : 0.0f;
    elementwise("mse_backward", pred.rows(), pred.cols(),
                {{pred, false}, {target, false}, {d_out, false, false, "d_out"}, {d_pred, true}}, {fw(inv_n)});
  }
  void kl_div_forward(const Tensor& pred, const Tensor& target, float eps, const Tensor& out) override {
    same(pred, target, "kl_div_forward", "pred", "target");
    check_shape(out, 1, 1, "kl_div_forward: out");
    GATCORE_CHECK(eps > 0.0f && std::isfinite(eps), "kl_div_forward: eps: must be finite and > 0, got ", eps);
    Launch l;
    l.u(pred.rows()).u(pred.cols()).t(pred, false, "pred").t(target, false, "target").t(out, true, "out").f(eps);
    l.run("kl_div_forward", 1);
  }
  void kl_div_backward(const Tensor& pred, const Tensor& target, float eps, const Tensor& d_out,
                       const Tensor& d_pred) override {
    if (!d_pred.defined()) return;
    same(pred, target, "kl_div_backward", "pred", "target");
    same(pred, d_pred, "kl_div_backward", "pred", "d_pred");
    check_shape(d_out, 1, 1, "kl_div_backward: d_out");
    GATCORE_CHECK(eps > 0.0f && std::isfinite(eps), "kl_div_backward: eps: must be finite and > 0, got ", eps);
    const float inv_rows = pred.rows() ? 1.0f / static_cast<float>(pred.rows()) : 0.0f;
    elementwise("kl_div_backward", pred.rows(), pred.cols(),
                {{pred, false}, {target, false}, {d_out, false, false, "d_out"}, {d_pred, true}},
                {fw(eps), fw(inv_rows)});
  }

  void adam_update(const Tensor& param, const Tensor& grad, const Tensor& m, const Tensor& v, float lr, float beta1,
                   float beta2, float eps, float weight_decay, long step) override {
    same(param, grad, "adam_update", "param", "grad");
    same(param, m, "adam_update", "param", "m");
    same(param, v, "adam_update", "param", "v");
    GATCORE_CHECK(step >= 1, "adam_update: step must be >= 1, got ", step);
    const float c1 = 1.0f / (1.0f - std::pow(beta1, static_cast<float>(step)));
    const float c2 = 1.0f / (1.0f - std::pow(beta2, static_cast<float>(step)));
    elementwise("adam_update", param.rows(), param.cols(), {{param, true}, {grad, false}, {m, true}, {v, true}},
                {fw(lr), fw(beta1), fw(beta2), fw(eps), fw(weight_decay), fw(c1), fw(c2)});
  }

  void attention_projection_forward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& el,
                                    const Tensor& er) override {
    check_vk(z, "attention_projection_forward: z");
    check_vk(a_l, "attention_projection_forward: a_l");
    const std::int64_t H = a_l.rows(), F = a_l.cols(), n = z.rows();
    check_shape(a_r, H, F, "attention_projection_forward: a_r");
    check_shape(z, n, H * F, "attention_projection_forward: z");
    check_shape(el, n, H, "attention_projection_forward: el");
    check_shape(er, n, H, "attention_projection_forward: er");
    Launch l;
    l.u(n).u(H).u(F).t(z, false, "z").t(a_l, false, "a_l").t(a_r, false, "a_r").t(el, true, "el").t(er, true, "er");
    l.per_subgroup("attention_projection_forward", static_cast<std::uint64_t>(n * H));
  }
  void attention_projection_backward(const Tensor& z, const Tensor& a_l, const Tensor& a_r, const Tensor& d_el,
                                     const Tensor& d_er, const Tensor& d_z, const Tensor& d_al,
                                     const Tensor& d_ar) override {
    check_vk(z, "attention_projection_backward: z");
    const std::int64_t H = a_l.rows(), F = a_l.cols(), n = z.rows();
    check_shape(a_r, H, F, "attention_projection_backward: a_r");
    check_shape(d_el, n, H, "attention_projection_backward: d_el");
    check_shape(d_er, n, H, "attention_projection_backward: d_er");
    if (d_z.defined()) {
      check_shape(d_z, n, H * F, "attention_projection_backward: d_z");
      Launch l;
      l.u(n).u(H).u(F).t(d_el, false, "d_el").t(d_er, false, "d_er").t(a_l, false, "a_l").t(a_r, false, "a_r");
      l.t(d_z, true, "d_z");
      l.per_invocation("attention_projection_backward_z", static_cast<std::uint64_t>(n * H * F));
    }
    if (d_al.defined() || d_ar.defined()) {
      if (d_al.defined()) check_shape(d_al, H, F, "attention_projection_backward: d_al");
      if (d_ar.defined()) check_shape(d_ar, H, F, "attention_projection_backward: d_ar");
      Launch l;
      l.u(n).u(H).u(F).t(z, false, "z").t(d_el, false, "d_el").t(d_er, false, "d_er");
      l.opt(d_al, true, "d_al").opt(d_ar, true, "d_ar").u(d_al.defined()).u(d_ar.defined());
      l.run("attention_projection_backward_a", static_cast<std::uint64_t>(H * F));
    }
  }
  void edge_softmax_additive_forward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                     const Tensor& alpha) override {
    const std::int64_t n = g.num_nodes, H = el.cols();
    check_vk(el, "edge_softmax_additive_forward: el");
    check_shape(el, n, H, "edge_softmax_additive_forward: el");
    check_shape(er, n, H, "edge_softmax_additive_forward: er");
    check_shape(alpha, g.num_edges(), H, "edge_softmax_additive_forward: alpha");
    const DeviceGraph& dg = device_graph(g);
    Launch l;
    l.u(n).u(H).t(el, false, "el").t(er, false, "er").t(alpha, true, "alpha").raw(*dg.indptr).raw(*dg.indices);
    l.f(slope);
    l.per_invocation("edge_softmax_additive_forward", static_cast<std::uint64_t>(n * H));
  }
  void edge_softmax_dot_forward(const CsrGraph& g, const Tensor& h, int heads, float scale,
                                const Tensor& alpha) override {
    const std::int64_t n = g.num_nodes, H = heads;
    check_vk(h, "edge_softmax_dot_forward: h");
    GATCORE_CHECK(H > 0 && h.cols() % H == 0, "edge_softmax_dot_forward: h ", h.shape_str(), " is not ", H,
                  " heads");
    check_shape(h, n, -1, "edge_softmax_dot_forward: h");
    check_shape(alpha, g.num_edges(), H, "edge_softmax_dot_forward: alpha");
    const DeviceGraph& dg = device_graph(g);
    Launch l;
    l.u(n).u(H).u(h.cols() / H).t(h, false, "h").t(alpha, true, "alpha").raw(*dg.indptr).raw(*dg.indices);
    l.f(scale);
    l.per_subgroup("edge_softmax_dot_forward", static_cast<std::uint64_t>(n * H));
  }
  void edge_softmax_additive_backward(const CsrGraph& g, const Tensor& el, const Tensor& er, float slope,
                                      const Tensor& alpha, const Tensor& d_alpha, const Tensor& d_el,
                                      const Tensor& d_er) override {
    const std::int64_t n = g.num_nodes, H = el.cols(), E = g.num_edges();
    check_shape(el, n, H, "edge_softmax_additive_backward: el");
    check_shape(er, n, H, "edge_softmax_additive_backward: er");
    check_shape(alpha, E, H, "edge_softmax_additive_backward: alpha");
    check_shape(d_alpha, E, H, "edge_softmax_additive_backward: d_alpha");
    if (!d_el.defined() && !d_er.defined()) return;
    if (d_el.defined()) check_shape(d_el, n, H, "edge_softmax_additive_backward: d_el");
    if (d_er.defined()) check_shape(d_er, n, H, "edge_softmax_additive_backward: d_er");
    const DeviceGraph& dg = device_graph(g);
    Tensor gs = empty(E, H, DType::f32);
    {
      Launch l;
      l.u(n).u(H).t(el, false, "el").t(er, false, "er").t(alpha, false, "alpha").t(d_alpha, false, "d_alpha");
      l.opt(d_el, true, "d_el").t(gs, true, "scratch").raw(*dg.indptr).raw(*dg.indices).f(slope).u(d_el.defined());
      l.per_invocation("edge_softmax_additive_backward", static_cast<std::uint64_t>(n * H));
    }
    if (d_er.defined()) gather_transpose(dg, gs, d_er);
  }
  void edge_softmax_dot_backward(const CsrGraph& g, const Tensor& h, int heads, float scale, const Tensor& alpha,
                                 const Tensor& d_alpha, const Tensor& d_h) override {
    const std::int64_t n = g.num_nodes, H = heads, E = g.num_edges();
    check_vk(h, "edge_softmax_dot_backward: h");
    GATCORE_CHECK(H > 0 && h.cols() % H == 0, "edge_softmax_dot_backward: h ", h.shape_str(), " is not ", H,
                  " heads");
    check_shape(alpha, E, H, "edge_softmax_dot_backward: alpha");
    check_shape(d_alpha, E, H, "edge_softmax_dot_backward: d_alpha");
    if (!d_h.defined()) return;
    check_shape(d_h, n, h.cols(), "edge_softmax_dot_backward: d_h");
    const DeviceGraph& dg = device_graph(g);
    Tensor gs = empty(E, H, DType::f32);
    {
      Launch l;
      l.u(n).u(H).t(alpha, false, "alpha").t(d_alpha, false, "d_alpha").t(gs, true, "scratch").raw(*dg.indptr);
      l.f(scale);
      l.per_invocation("edge_softmax_dot_backward", static_cast<std::uint64_t>(n * H));
    }
    logit_gradient_to_h(dg, h, H, gs, d_h);
  }
  void aggregate_forward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& out) override {
    const std::int64_t n = g.num_nodes, H = alpha.cols();
    check_vk(z, "aggregate_forward: z");
    check_shape(alpha, g.num_edges(), -1, "aggregate_forward: alpha");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "aggregate_forward: z ", z.shape_str(), " is not ", H, " heads");
    check_shape(z, n, -1, "aggregate_forward: z");
    check_shape(out, n, z.cols(), "aggregate_forward: out");
    const DeviceGraph& dg = device_graph(g);
    Launch l;
    l.u(n).u(H).u(z.cols() / H).t(alpha, false, "alpha").t(z, false, "z").t(out, true, "out");
    l.raw(*dg.indptr).raw(*dg.indices);
    l.per_invocation("aggregate_forward", static_cast<std::uint64_t>(n * z.cols()));
  }
  void aggregate_backward(const CsrGraph& g, const Tensor& alpha, const Tensor& z, const Tensor& d_out,
                          const Tensor& d_alpha, const Tensor& d_z) override {
    const std::int64_t n = g.num_nodes, H = alpha.cols();
    check_vk(z, "aggregate_backward: z");
    check_shape(alpha, g.num_edges(), -1, "aggregate_backward: alpha");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "aggregate_backward: z ", z.shape_str(), " is not ", H, " heads");
    check_shape(d_out, n, z.cols(), "aggregate_backward: d_out");
    const DeviceGraph& dg = device_graph(g);
    const std::int64_t F = z.cols() / H;
    if (d_alpha.defined()) {
      check_shape(d_alpha, g.num_edges(), H, "aggregate_backward: d_alpha");
      Launch l;
      l.u(n).u(H).u(F).t(d_out, false, "d_out").t(z, false, "z").t(d_alpha, true, "d_alpha");
      l.raw(*dg.indptr).raw(*dg.indices);
      l.per_subgroup("aggregate_backward_alpha", static_cast<std::uint64_t>(n * H));
    }
    if (d_z.defined()) {
      check_shape(d_z, n, z.cols(), "aggregate_backward: d_z");
      Launch l;
      l.u(n).u(H).u(F).t(alpha, false, "alpha").t(d_out, false, "d_out").t(d_z, true, "d_z");
      l.raw(*dg.out_ptr).raw(*dg.out_dst).raw(*dg.out_edge);
      l.per_invocation("aggregate_backward_z", static_cast<std::uint64_t>(n * z.cols()));
    }
  }
  // Fused ops: one row shader each (forward: logits + softmax + aggregation,
  // only alpha stored; backward: d_alpha formed on the fly, the logit
  // gradient left in a cached scratch [E, H] for the transpose gathers), plus
  // the gathers shared with the unfused backwards.
  void gat_fused_additive_forward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                  float slope, const Tensor& out, const Tensor& alpha) override {
    const std::int64_t n = g.num_nodes, H = el.cols();
    check_vk(z, "gat_fused_additive_forward: z");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "gat_fused_additive_forward: z ", z.shape_str(), " is not ", H,
                  " heads");
    check_shape(z, n, -1, "gat_fused_additive_forward: z");
    check_shape(el, n, H, "gat_fused_additive_forward: el");
    check_shape(er, n, H, "gat_fused_additive_forward: er");
    check_shape(out, n, z.cols(), "gat_fused_additive_forward: out");
    check_shape(alpha, g.num_edges(), H, "gat_fused_additive_forward: alpha");
    const DeviceGraph& dg = device_graph(g);
    Launch l;
    l.u(n).u(H).u(z.cols() / H).t(z, false, "z").t(el, false, "el").t(er, false, "er").t(out, true, "out");
    l.t(alpha, true, "alpha").raw(*dg.indptr).raw(*dg.indices).f(slope);
    l.per_subgroup("gat_fused_additive_forward", static_cast<std::uint64_t>(n * H));
  }
  void gat_fused_dot_forward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& out,
                             const Tensor& alpha) override {
    const std::int64_t n = g.num_nodes, H = heads;
    check_vk(z, "gat_fused_dot_forward: z");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "gat_fused_dot_forward: z ", z.shape_str(), " is not ", H, " heads");
    check_shape(z, n, -1, "gat_fused_dot_forward: z");
    check_shape(out, n, z.cols(), "gat_fused_dot_forward: out");
    check_shape(alpha, g.num_edges(), H, "gat_fused_dot_forward: alpha");
    const DeviceGraph& dg = device_graph(g);
    Launch l;
    l.u(n).u(H).u(z.cols() / H).t(z, false, "z").t(out, true, "out").t(alpha, true, "alpha");
    l.raw(*dg.indptr).raw(*dg.indices).f(scale);
    l.per_subgroup("gat_fused_dot_forward", static_cast<std::uint64_t>(n * H));
  }
  void gat_fused_additive_backward(const CsrGraph& g, const Tensor& z, const Tensor& el, const Tensor& er,
                                   float slope, const Tensor& alpha, const Tensor& d_out, const Tensor& d_z,
                                   const Tensor& d_el, const Tensor& d_er) override {
    const std::int64_t n = g.num_nodes, H = alpha.cols(), E = g.num_edges();
    check_vk(z, "gat_fused_additive_backward: z");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "gat_fused_additive_backward: z ", z.shape_str(), " is not ", H,
                  " heads");
    check_shape(z, n, -1, "gat_fused_additive_backward: z");
    check_shape(alpha, E, H, "gat_fused_additive_backward: alpha");
    check_shape(el, n, H, "gat_fused_additive_backward: el");
    check_shape(er, n, H, "gat_fused_additive_backward: er");
    check_shape(d_out, n, z.cols(), "gat_fused_additive_backward: d_out");
    if (d_el.defined()) check_shape(d_el, n, H, "gat_fused_additive_backward: d_el");
    if (d_er.defined()) check_shape(d_er, n, H, "gat_fused_additive_backward: d_er");
    if (d_el.defined() || d_er.defined()) {
      const DeviceGraph& dg = device_graph(g);
      Tensor gs = empty(E, H, DType::f32);
      Launch l;
      l.u(n).u(H).u(z.cols() / H).t(z, false, "z").t(el, false, "el").t(er, false, "er").t(alpha, false, "alpha");
      l.t(d_out, false, "d_out").opt(d_el, true, "d_el").t(gs, true, "scratch").raw(*dg.indptr).raw(*dg.indices);
      l.f(slope).u(d_el.defined());
      l.per_subgroup("gat_fused_additive_backward", static_cast<std::uint64_t>(n * H));
      if (d_er.defined()) gather_transpose(dg, gs, d_er);
    }
    if (d_z.defined()) aggregate_backward(g, alpha, z, d_out, Tensor(), d_z);
  }
  void gat_fused_dot_backward(const CsrGraph& g, const Tensor& z, int heads, float scale, const Tensor& alpha,
                              const Tensor& d_out, const Tensor& d_z) override {
    const std::int64_t n = g.num_nodes, H = heads, E = g.num_edges();
    check_vk(z, "gat_fused_dot_backward: z");
    GATCORE_CHECK(H > 0 && z.cols() % H == 0, "gat_fused_dot_backward: z ", z.shape_str(), " is not ", H, " heads");
    check_shape(z, n, -1, "gat_fused_dot_backward: z");
    check_shape(alpha, E, H, "gat_fused_dot_backward: alpha");
    check_shape(d_out, n, z.cols(), "gat_fused_dot_backward: d_out");
    if (!d_z.defined()) return;
    check_shape(d_z, n, z.cols(), "gat_fused_dot_backward: d_z");
    const DeviceGraph& dg = device_graph(g);
    Tensor gs = empty(E, H, DType::f32);
    Launch l;
    l.u(n).u(H).u(z.cols() / H).t(z, false, "z").t(alpha, false, "alpha").t(d_out, false, "d_out");
    l.t(gs, true, "scratch").raw(*dg.indptr).raw(*dg.indices).f(scale);
    l.per_subgroup("gat_fused_dot_backward", static_cast<std::uint64_t>(n * H));
    logit_gradient_to_h(dg, z, H, gs, d_z);
    aggregate_backward(g, alpha, z, d_out, Tensor(), d_z);
  }

  void segment_max_forward(const Tensor& x, std::span<const std::int64_t> seg, const Tensor& out,
                           const Tensor& argmax) override {
    check_vk(x, "segment_max_forward: x");
    const auto sp = upload_segments(seg, x.rows(), "segment_max_forward");
    const std::int64_t S = static_cast<std::int64_t>(seg.size()) - 1, C = x.cols();
    check_shape(out, S, C, "segment_max_forward: out");
    check_shape(argmax, S, C, "segment_max_forward: argmax");
    GATCORE_CHECK(argmax.dtype() == DType::i32, "segment_max_forward: argmax must be int32");
    Launch l;
    l.u(S).u(C).t(x, false, "x").t(out, true, "out").t(argmax, true, "argmax").raw(*sp);
    l.per_invocation("segment_max_forward", static_cast<std::uint64_t>(S * C));
  }
  void segment_max_backward(const Tensor& d_out, const Tensor& argmax, const Tensor& d_x) override {
    check_vk(d_out, "segment_max_backward: d_out");
    check_shape(argmax, d_out.rows(), d_out.cols(), "segment_max_backward: argmax");
    GATCORE_CHECK(argmax.dtype() == DType::i32, "segment_max_backward: argmax must be int32");
    if (!d_x.defined()) return;
    check_shape(d_x, -1, d_out.cols(), "segment_max_backward: d_x");
    Launch l;
    l.u(d_out.rows()).u(d_out.cols()).t(d_out, false, "d_out").t(argmax, false, "argmax").t(d_x, true, "d_x");
    l.per_invocation("segment_max_backward", static_cast<std::uint64_t>(d_out.numel()));
  }
  void broadcast_segments_forward(const Tensor& x, std::span<const std::int64_t> seg, const Tensor& out) override {
    check_vk(x, "broadcast_segments_forward: x");
    check_vk(out, "broadcast_segments_forward: out");
    const auto sp = upload_segments(seg, out.rows(), "broadcast_segments_forward");
    const std::int64_t S = static_cast<std::int64_t>(seg.size()) - 1;
    check_shape(x, S, out.cols(), "broadcast_segments_forward: x");
    if (S == 0) return;
    Launch l;
    l.u(out.rows()).u(out.cols()).u(S).t(x, false, "x").t(out, true, "out").raw(*sp);
    l.per_invocation("broadcast_segments_forward", static_cast<std::uint64_t>(out.numel()));
  }
  void broadcast_segments_backward(const Tensor& d_out, std::span<const std::int64_t> seg,
                                   const Tensor& d_x) override {
    check_vk(d_out, "broadcast_segments_backward: d_out");
    const auto sp = upload_segments(seg, d_out.rows(), "broadcast_segments_backward");
    if (!d_x.defined()) return;
    const std::int64_t S = static_cast<std::int64_t>(seg.size()) - 1;
    check_shape(d_x, S, d_out.cols(), "broadcast_segments_backward: d_x");
    Launch l;
    l.u(S).u(d_out.cols()).t(d_out, false, "d_out").t(d_x, true, "d_x").raw(*sp);
    l.per_invocation("broadcast_segments_backward", static_cast<std::uint64_t>(S * d_out.cols()));
  }
  void neighbour_mean_forward(const CsrGraph& nbr, const Tensor& x, const Tensor& out) override {
    check_vk(x, "neighbour_mean_forward: x");
    check_shape(out, nbr.num_nodes, x.cols(), "neighbour_mean_forward: out");
    const DeviceGraph& dg = device_graph(nbr);
    Launch l;
    l.u(nbr.num_nodes).u(x.cols()).t(x, false, "x").t(out, true, "out").raw(*dg.indptr).raw(*dg.indices);
    l.per_invocation("neighbour_mean_forward", static_cast<std::uint64_t>(out.numel()));
  }
  void neighbour_mean_backward(const CsrGraph& nbr, const Tensor& d_out, const Tensor& d_x) override {
    check_vk(d_out, "neighbour_mean_backward: d_out");
    check_shape(d_out, nbr.num_nodes, -1, "neighbour_mean_backward: d_out");
    if (!d_x.defined()) return;
    check_shape(d_x, nbr.num_nodes, d_out.cols(), "neighbour_mean_backward: d_x");
    const DeviceGraph& dg = device_graph(nbr);
    Launch l;
    l.u(nbr.num_nodes).u(d_out.cols()).t(d_out, false, "d_out").t(d_x, true, "d_x");
    l.raw(*dg.indptr).raw(*dg.out_ptr).raw(*dg.out_dst);
    l.per_invocation("neighbour_mean_backward", static_cast<std::uint64_t>(d_x.numel()));
  }

 private:
  // d_h[i] += Σ_e g_e h_j (row side) + Σ_e' g_e' h_d (source side, over the transpose).
  void logit_gradient_to_h(const DeviceGraph& dg, const Tensor& h, std::int64_t H, const Tensor& gs,
                           const Tensor& d_h) {
    Launch l;
    l.u(dg.num_nodes).u(H).u(h.cols() / H).t(h, false, "h").t(gs, false, "scratch").t(d_h, true, "d_h");
    l.raw(*dg.indptr).raw(*dg.indices).raw(*dg.out_ptr).raw(*dg.out_dst).raw(*dg.out_edge);
    l.per_invocation("edge_softmax_dot_backward_h", static_cast<std::uint64_t>(dg.num_nodes * h.cols()));
  }
  // Segment offsets (validated as the CPU kernels do) uploaded as int32; the
  // storage is released after recording and reused once the work completes.
  static std::shared_ptr<Storage> upload_segments(std::span<const std::int64_t> seg, std::int64_t n, const char* fn) {
    GATCORE_CHECK(!seg.empty(), fn, ": seg_ptr: empty (needs S + 1 offsets)");
    GATCORE_CHECK(seg.front() == 0 && seg.back() == n, fn, ": seg_ptr: must start at 0 and end at the row count ", n,
                  ", got [", seg.front(), ", ..., ", seg.back(), "]");
    std::vector<std::int32_t> v(seg.size());
    for (std::size_t s = 0; s < seg.size(); ++s) {
      if (s) GATCORE_CHECK(seg[s - 1] <= seg[s], fn, ": seg_ptr: decreases at ", s, " (", seg[s - 1], " > ", seg[s], ")");
      v[s] = static_cast<std::int32_t>(u32(seg[s], "segment offset"));
    }
    return upload(v.data(), v.size() * 4);
  }
  void batchnorm_forward(std::uint32_t mode, const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                         float momentum, const Tensor& y, const Tensor& smean, const Tensor& sinv, const Tensor& rm,
                         const Tensor& rv) {
    const std::int64_t C = x.cols();
    for (const Tensor* t : {&gamma, &beta, &smean, &sinv, &rm, &rv})
      if (t->defined()) check_shape(*t, 1, C, "batchnorm: per-column parameter");
    if (x.rows() == 0 || C == 0) return;
    Launch l;
    l.u(x.rows()).u(C).t(x, false, "x").opt(gamma, false, "gamma").opt(beta, false, "beta").t(y, true, "y");
    l.opt(smean, true, "save_mean").opt(sinv, true, "save_invstd").opt(rm, mode == 0, "running_mean");
    l.opt(rv, mode == 0, "running_var").u(mode).f(eps).f(momentum);
    for (const Tensor* t : {&gamma, &beta, &smean, &sinv, &rm, &rv}) l.u(t->defined());
    l.run("batchnorm_forward", static_cast<std::uint64_t>(C));
  }
  void batchnorm_backward(std::uint32_t mode, const Tensor& x, const Tensor& gamma, const Tensor& mean,
                          const Tensor& stat, float eps, const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma,
                          const Tensor& d_beta) {
    check_vk(x, "batchnorm backward: x");
    const std::int64_t C = x.cols();
    same(x, d_y, "batchnorm backward", "x", "d_y");
    if (d_x.defined()) same(x, d_x, "batchnorm backward", "x", "d_x");
    if (gamma.defined()) check_shape(gamma, 1, C, "batchnorm backward: gamma");
    if (d_gamma.defined()) check_shape(d_gamma, 1, C, "batchnorm backward: d_gamma");
    if (d_beta.defined()) check_shape(d_beta, 1, C, "batchnorm backward: d_beta");
    if ((!d_x.defined() && !d_gamma.defined() && !d_beta.defined()) || x.rows() == 0 || C == 0) return;
    Launch l;
    l.u(x.rows()).u(C).t(x, false, "x").opt(gamma, false, "gamma").t(mean, false, "mean").t(stat, false, "stat");
    l.t(d_y, false, "d_y").opt(d_x, true, "d_x").opt(d_gamma, true, "d_gamma").opt(d_beta, true, "d_beta");
    l.u(mode).f(eps).u(gamma.defined()).u(d_x.defined()).u(d_gamma.defined()).u(d_beta.defined());
    l.run("batchnorm_backward", static_cast<std::uint64_t>(C));
  }

  // d_x[j,k] += Σ over edges e leaving j of gs[e,k].
  void gather_transpose(const DeviceGraph& dg, const Tensor& gs, const Tensor& d_x) {
    Launch l;
    l.u(dg.num_nodes).u(d_x.cols()).t(gs, false, "scratch").t(d_x, true, "d_x").raw(*dg.out_ptr).raw(*dg.out_edge);
    l.per_invocation("edge_softmax_backward_gather", static_cast<std::uint64_t>(dg.num_nodes * d_x.cols()));
  }
};

VulkanBackend g_backend;

}  // namespace

Backend* backend_instance() { return &g_backend; }

}  // namespace gatcore::vk
