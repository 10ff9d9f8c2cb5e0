#include "gatcore/dist/data_parallel.hpp"

#include <algorithm>

#include "gatcore/backend.hpp"

namespace gatcore::dist {

Share share_of(std::size_t count, int rank, int size) {
  GATCORE_CHECK(size >= 1 && rank >= 0 && rank < size, "share_of: rank ", rank, " of ", size);
  const auto at = [&](int r) { return count * std::size_t(r) / std::size_t(size); };
  return {at(rank), at(rank + 1)};
}

namespace {
// `t` on the host, contiguous (the tensor itself when it already is).
Tensor host(const Tensor& t) {
  const Tensor h = t.device() == Device::cpu ? t : to(t, Device::cpu);
  return h.contiguous() ? h : h.clone();
}
void store(const Tensor& src_host, const Tensor& dst) {
  if (dst.device() == Device::cpu) dst.copy_from_(src_host);
  else backend(dst.device()).copy(to(src_host, dst.device()), dst);
}
}  // namespace

void sum_gradients(Communicator& comm, const std::vector<Var>& params) {
  if (comm.size() == 1) return;
  std::size_t total = params.size();
  for (const Var& p : params) total += std::size_t(p.value().numel());
  std::vector<float> flat(total, 0.f);
  std::size_t off = params.size();
  for (std::size_t k = 0; k < params.size(); ++k) {
    const std::size_t n = std::size_t(params[k].value().numel());
    if (const Tensor g = params[k].grad(); g.defined()) {
      flat[k] = 1.f;
      const Tensor h = host(g);
      std::copy(h.data(), h.data() + n, flat.data() + off);
    }
    off += n;
  }
  comm.sum(flat.data(), flat.size());
  off = params.size();
  for (std::size_t k = 0; k < params.size(); ++k) {
    const Var& p = params[k];
    const std::size_t n = std::size_t(p.value().numel());
    if (flat[k] == 0.f) {
      p.zero_grad();
    } else {
      Tensor h = Tensor::empty(p.rows(), p.cols());
      std::copy(flat.data() + off, flat.data() + off + n, h.data());
      store(h, p.grad_or_zeros());
    }
    off += n;
  }
}

void broadcast_tensors(Communicator& comm, const std::vector<Tensor>& tensors, int root) {
  if (comm.size() == 1) return;
  for (const Tensor& t : tensors) {
    const Tensor h = host(t);
    comm.broadcast(h.data(), std::size_t(h.numel()) * sizeof(float), root);
    const bool in_place = t.device() == Device::cpu && t.contiguous();
    if (comm.rank() != root && !in_place) store(h, t);
  }
}

}  // namespace gatcore::dist
