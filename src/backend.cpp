// The backend registry: which Backend runs the ops of each device. The CPU
// backend (src/backends/cpu/) fills its slot unless one was registered in its
// place; other backends register themselves when initialised.
#include <array>

#include "gatcore/backend.hpp"
#include "src/backends/cpu/backend_cpu.hpp"

namespace gatcore {

namespace {

std::array<Backend*, 2> g_backends{nullptr, nullptr};

Backend* slot(Device d) {
  Backend* b = g_backends[static_cast<std::size_t>(d)];
  return b || d != Device::cpu ? b : &cpu_backend();
}

}  // namespace

void Backend::batchnorm_train_forward_across(const Tensor&, const Tensor&, const Tensor&, float, float,
                                             const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                                             const Tensor&, const SumAcross&) {
  throw Error("batch_norm: a batch split over processes (SyncBatchNorm) runs on the CPU backend only; "
              "train data-parallel on --device cpu");
}
void Backend::batchnorm_train_backward_across(const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                                              const Tensor&, const Tensor&, const Tensor&, const Tensor&,
                                              const SumAcross&) {
  throw Error("batch_norm: a batch split over processes (SyncBatchNorm) runs on the CPU backend only; "
              "train data-parallel on --device cpu");
}

// The fused BatchNorm → activation as the unfused kernels: u = BatchNorm(x)
// into a temporary, then the activation (backward: u again, f'(u) ⊙ d_y,
// then BatchNorm's backward). save_affine is not used.
void Backend::batchnorm_act_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                          float momentum, Activation f, float slope, const Tensor& y,
                                          const Tensor& save_mean, const Tensor& save_invstd, const Tensor&,
                                          const Tensor& running_mean, const Tensor& running_var,
                                          const SumAcross& across) {
  Tensor u = empty(x.rows(), x.cols());
  if (across)
    batchnorm_train_forward_across(x, gamma, beta, eps, momentum, u, save_mean, save_invstd, running_mean,
                                   running_var, across);
  else
    batchnorm_train_forward(x, gamma, beta, eps, momentum, u, save_mean, save_invstd, running_mean, running_var);
  activation_forward(f, u, y, slope);
}
void Backend::batchnorm_act_apply(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, Activation f,
                                  float slope, const Tensor&, const Tensor&, const Tensor& y) {
  // The batch statistics again (deterministic: the forward's), running statistics left alone.
  Tensor u = empty(x.rows(), x.cols());
  batchnorm_train_forward(x, gamma, beta, eps, 0.0f, u, Tensor{}, Tensor{}, Tensor{}, Tensor{});
  activation_forward(f, u, y, slope);
}
void Backend::batchnorm_act_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps,
                                           Activation f, float slope, const Tensor& save_mean,
                                           const Tensor& save_invstd, const Tensor&, const Tensor& d_y,
                                           const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta,
                                           const SumAcross& across, bool accumulate_dx) {
  Tensor u = empty(x.rows(), x.cols()), d_u = empty(x.rows(), x.cols());
  if (across)
    batchnorm_train_forward_across(x, gamma, beta, eps, 0.0f, u, Tensor{}, Tensor{}, Tensor{}, Tensor{}, across);
  else
    batchnorm_train_forward(x, gamma, beta, eps, 0.0f, u, Tensor{}, Tensor{}, Tensor{}, Tensor{});
  activation_backward(f, u, Tensor{}, d_y, d_u, slope, false);
  if (across) {
    // (the across backward has no write mode: a fresh d_x is cleared first)
    if (!accumulate_dx && d_x.defined()) fill(d_x, 0.0f);
    batchnorm_train_backward_across(x, gamma, save_mean, save_invstd, d_u, d_x, d_gamma, d_beta, across);
  } else {
    batchnorm_train_backward(x, gamma, save_mean, save_invstd, d_u, d_x, d_gamma, d_beta, accumulate_dx);
  }
}

Backend& backend(Device d) {
  Backend* b = slot(d);
  if (!b)
    throw Error(detail::cat("no backend for device '", device_name(d),
                            "': gatcore was built without it or it was not initialised"));
  return *b;
}

void register_backend(Backend* b) {
  GATCORE_CHECK(b != nullptr, "register_backend: null backend");
  g_backends[static_cast<std::size_t>(b->device())] = b;
}

void unregister_backend(Device d) {
  GATCORE_CHECK(d != Device::cpu, "unregister_backend: the CPU backend is always present");
  g_backends[static_cast<std::size_t>(d)] = nullptr;
}

bool has_backend(Device d) { return slot(d) != nullptr; }

Tensor to(const Tensor& t, Device d) {
  if (!t.defined() || t.device() == d) return t;
  if (t.device() == Device::cpu) return backend(d).from_host(t);
  Tensor host = backend(t.device()).to_host(t);
  return d == Device::cpu ? host : backend(d).from_host(host);
}

}  // namespace gatcore
