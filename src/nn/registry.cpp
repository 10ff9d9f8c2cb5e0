#include "gatcore/nn/registry.hpp"

#include <utility>

#include "gatcore/backend.hpp"

namespace gatcore::nn {

Var Registry::add_param(const std::string& name, Tensor value) {
  GATCORE_CHECK(!find_param(name) && !find_buffer(name), "Registry: duplicate name '", name, "'");
  Var v = Var::parameter(std::move(value), name);
  params.push_back({name, v});
  return v;
}

void Registry::add_buffer(const std::string& name, Tensor value) {
  GATCORE_CHECK(!find_param(name) && !find_buffer(name), "Registry: duplicate name '", name, "'");
  buffers.push_back({name, std::move(value)});
}

std::vector<Var> Registry::parameters() const {
  std::vector<Var> out;
  out.reserve(params.size());
  for (const auto& p : params) out.push_back(p.var);
  return out;
}

const Var* Registry::find_param(const std::string& name) const {
  for (const auto& p : params)
    if (p.name == name) return &p.var;
  return nullptr;
}

const Tensor* Registry::find_buffer(const std::string& name) const {
  for (const auto& b : buffers)
    if (b.name == name) return &b.tensor;
  return nullptr;
}

std::int64_t Registry::num_parameters() const {
  std::int64_t n = 0;
  for (const auto& p : params) n += p.var.value().numel();
  return n;
}

void move_storage(const Tensor& t, Device d) {
  if (!t.defined() || t.device() == d) return;
  GATCORE_CHECK(t.offset() == 0 && t.contiguous(), "move_storage: tensor ", t.shape_str(),
                " is a view; only whole storages move in place");
  Tensor moved = to(t, d);
  Storage& a = *t.storage();
  Storage& b = *moved.storage();
  std::swap(a.host, b.host);
  std::swap(a.bytes, b.bytes);
  std::swap(a.device, b.device);
  std::swap(a.handle, b.handle);
  std::swap(a.release, b.release);
  ++a.version;
}

void Registry::to(Device d) {
  for (auto& p : params) {
    p.var.zero_grad();
    move_storage(p.var.value(), d);
  }
  for (auto& b : buffers) move_storage(b.tensor, d);
}

}  // namespace gatcore::nn
