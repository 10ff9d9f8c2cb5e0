#pragma once
// Seeded, platform-independent random numbers for initialisation, dropout and
// vertex sampling. std::mt19937_64 is specified bit-exactly by the standard;
// the distributions below are our own (the std:: ones are not portable).
#include <cstdint>
#include <random>

#include "gatcore/tensor.hpp"

namespace gatcore::nn {

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) : eng_(seed) {}
  std::uint64_t next() { return eng_(); }
  float uniform() { return float(eng_() >> 40) * 0x1.0p-24f; }  // [0, 1)
  float uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }
  std::uint64_t below(std::uint64_t n) { return n ? eng_() % n : 0; }  // [0, n), bias negligible
  float normal();
  std::mt19937_64& engine() { return eng_; }

 private:
  std::mt19937_64 eng_;
};

enum class Init { glorot, he, zeros };

// Glorot / He uniform for a [fan_in, fan_out] weight.
Tensor init_weight(std::int64_t fan_in, std::int64_t fan_out, Init init, Rng& rng);
Tensor uniform_tensor(std::int64_t rows, std::int64_t cols, float bound, Rng& rng);

}  // namespace gatcore::nn
