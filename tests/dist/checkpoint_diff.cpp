// checkpoint_diff A.gcm B.gcm [--rel R | --lr LR --tol T --significant F]
//
// Compares two checkpoints tensor by tensor (by name). Without options: exits
// 0 only if they are bitwise identical. With --rel (gradients): every value
// must agree to R·(the largest |value| of A). With --lr: the check for two Adam runs
// whose gradients differ by float rounding (tests/dist/dist_train.sh).
// Adam moves every parameter by about lr·m/√v per step whatever the
// gradient's size, so a parameter whose gradient is zero up to rounding (a
// bias right before a BatchNorm, which the BatchNorm cancels) takes
// rounding-driven steps of ~lr in any run; its value is noise in both runs
// and is not compared. The parameters that carry a gradient, those with
// √v ≥ F·max √v over the whole model in A (v: Adam's second moment), must
// agree to T·lr. Prints the largest differences and what was compared.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "gatcore/models/checkpoint.hpp"

using namespace gatcore;
using namespace gatcore::models;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: checkpoint_diff A.gcm B.gcm [--lr LR --tol T --significant F]\n");
    return 2;
  }
  double lr = 0, tol = 0, significant = 1e-2, rel = -1;
  for (int i = 3; i + 1 < argc; ++i) {
    if (!std::strcmp(argv[i], "--lr")) lr = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--tol")) tol = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--significant")) significant = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--rel")) rel = std::atof(argv[++i]);
  }
  try {
    const CheckpointFile a = read_checkpoint_file(argv[1]), b = read_checkpoint_file(argv[2]);
    if (a.tensors.size() != b.tensors.size()) {
      std::printf("different tensor counts: %zu vs %zu\n", a.tensors.size(), b.tensors.size());
      return 1;
    }
    std::size_t total = 0, differing = 0, compared = 0, skipped = 0;
    double vmax = 0;  // the model's largest √v
    for (const auto& [name, t] : a.tensors)
      if (name.rfind("optim.v.", 0) == 0)
        for (std::int64_t i = 0; i < t.rows(); ++i)
          for (std::int64_t j = 0; j < t.cols(); ++j) vmax = std::max(vmax, std::sqrt(double(t.at(i, j))));
    double worst = 0;  // |Δ| / lr over the compared parameters
    std::string worst_name;
    for (const auto& [name, ta] : a.tensors) {
      const Tensor* tb = b.find(name);
      if (!tb || !tb->same_shape(ta)) {
        std::printf("tensor %s: missing or of another shape in %s\n", name.c_str(), argv[2]);
        return 1;
      }
      const Tensor* v = name.rfind("optim.", 0) == 0 ? nullptr : a.find("optim.v." + name);
      for (std::int64_t i = 0; i < ta.rows(); ++i)
        for (std::int64_t j = 0; j < ta.cols(); ++j) {
          const double x = ta.at(i, j), y = tb->at(i, j), d = std::fabs(x - y);
          ++total;
          if (!(d == 0)) ++differing;
          if (!v || lr <= 0) continue;
          if (std::sqrt(double(v->at(i, j))) < significant * vmax) {
            ++skipped;
            continue;
          }
          ++compared;
          const double r = std::isfinite(d) ? d / lr : INFINITY;
          if (r > worst) worst = r, worst_name = name + "[" + std::to_string(i) + "," + std::to_string(j) + "]";
        }
    }
    std::printf("%zu tensors, %zu values, %zu differ\n", a.tensors.size(), total, differing);
    if (rel >= 0) {
      double amax = 0, dmax = 0;
      std::string at;
      for (const auto& [name, ta] : a.tensors) {
        const Tensor& tb = *b.find(name);
        for (std::int64_t i = 0; i < ta.rows(); ++i)
          for (std::int64_t j = 0; j < ta.cols(); ++j) {
            amax = std::max(amax, std::fabs(double(ta.at(i, j))));
            const double d = std::fabs(double(ta.at(i, j)) - double(tb.at(i, j)));
            if (!(d <= dmax)) dmax = std::isfinite(d) ? d : INFINITY, at = name;
          }
      }
      std::printf("largest difference %.3g of the largest value %.3g (%s)\n", dmax / amax, amax,
                  at.empty() ? "-" : at.c_str());
      if (!(dmax <= rel * amax)) {
        std::printf("FAIL: above %g\n", rel);
        return 1;
      }
      std::printf("within %g\n", rel);
      return 0;
    }
    if (lr <= 0) {
      std::printf(differing ? "FAIL: not identical\n" : "identical\n");
      return differing ? 1 : 0;
    }
    std::printf("parameters with a gradient (sqrt v >= %g max): %zu compared, %zu rounding-driven skipped; "
                "largest difference %.3g lr at %s\n",
                significant, compared, skipped, worst, worst_name.empty() ? "-" : worst_name.c_str());
    if (!(worst <= tol)) {
      std::printf("FAIL: above the tolerance %g lr\n", tol);
      return 1;
    }
    std::printf("within %g lr\n", tol);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "checkpoint_diff: %s\n", e.what());
    return 2;
  }
}
