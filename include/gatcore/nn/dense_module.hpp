#pragma once
// A DenseGATs dense module: L GAT blocks writing into one DenseNet buffer
// [n, in + L·w]. The caller writes the module input into columns [0, in)
// (via `into=` of whatever produces it, see input_slot()); block m reads
// columns [0, in + m·w) and writes [in + m·w, in + (m+1)·w). No copies.
// With dense = false (the "w/o dense connections" ablation) block m reads
// only the previous block's slot and the module output is the last slot.
#include <vector>

#include "gatcore/nn/gat_block.hpp"

namespace gatcore::nn {

struct DenseModule {
  std::vector<GatBlock> blocks;  // "blocks.0", ...
  std::int64_t in = 0, block_width = 0;
  bool dense = true;

  DenseModule() = default;
  DenseModule(const Scope& s, std::int64_t in, int num_blocks, const GatBlockOptions& opt, bool dense, Rng& rng);
  std::int64_t buffer_width() const { return in + std::int64_t(blocks.size()) * block_width; }
  std::int64_t out() const { return dense ? buffer_width() : (blocks.empty() ? in : block_width); }
  Var make_buffer(std::int64_t n, Device d = Device::cpu) const;  // uninitialised [n, buffer_width] on d
  static Var input_slot(const Var& buf, std::int64_t in) { return buf.cols_slice(0, in); }
  // Runs every block; returns the module output (a view of buf).
  Var forward(const GraphPtr& g, const Var& buf, bool training);
};

}  // namespace gatcore::nn
