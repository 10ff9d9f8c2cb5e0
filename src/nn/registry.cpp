#include "gatcore/nn/registry.hpp"

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

}  // namespace gatcore::nn
