#pragma once
// Parameter registry with hierarchical names.
//
// Every layer is a plain struct built from a Scope: a registry pointer plus a
// name prefix ("modules.1.blocks.3."). Parameters (trainable Vars) and
// buffers (non-trainable tensors such as BatchNorm running statistics) are
// registered under their full name, in construction order, so a model's
// parameter list, its optimiser state and its checkpoint all share one
// deterministic order and readable names.
#include <cstdint>
#include <string>
#include <vector>

#include "gatcore/autograd.hpp"

namespace gatcore::nn {

struct Registry {
  struct Param {
    std::string name;
    Var var;
  };
  struct Buffer {
    std::string name;
    Tensor tensor;
  };
  std::vector<Param> params;
  std::vector<Buffer> buffers;

  // Throws InvalidArgument on a duplicate name.
  Var add_param(const std::string& name, Tensor value);
  void add_buffer(const std::string& name, Tensor value);

  std::vector<Var> parameters() const;
  const Var* find_param(const std::string& name) const;
  const Tensor* find_buffer(const std::string& name) const;
  std::int64_t num_parameters() const;  // scalar count
  // Moves every parameter and buffer to device `d` in place: the storages
  // shared with the layers (Vars, BatchNorm running statistics) now hold
  // device memory, so every holder sees the move. Gradients are dropped.
  void to(Device d);
};

// Moves the whole storage of `t` (offset 0, contiguous) to device `d` in
// place: every tensor sharing that storage follows.
void move_storage(const Tensor& t, Device d);

// A registry and a name prefix. sub("blocks").sub(3) -> "blocks.3.".
struct Scope {
  Registry* reg = nullptr;
  std::string prefix;

  Scope sub(const std::string& name) const { return {reg, prefix + name + "."}; }
  Scope sub(std::int64_t index) const { return sub(std::to_string(index)); }
  Var param(const std::string& name, Tensor value) const { return reg->add_param(prefix + name, std::move(value)); }
  void buffer(const std::string& name, Tensor value) const { reg->add_buffer(prefix + name, std::move(value)); }
};

}  // namespace gatcore::nn
