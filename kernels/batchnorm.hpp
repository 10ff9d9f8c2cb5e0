#pragma once
// BatchNorm1d over the rows (nodes) of x: [n, C]. Statistics in double
// precision for stability on 10^5 rows. gamma / beta may be undefined (no
// affine part); training needs at least 2 rows.
#include "gatcore/batch_split.hpp"
#include "gatcore/tensor.hpp"

namespace gatcore::cpu {

// Training: batch mean / biased variance; saves mean and invstd ([1, C]) for
// backward and updates running stats (unbiased variance) with `momentum`
// (running = (1-m) running + m batch) when they are defined.
// `across` (SyncBatchNorm, data-parallel training): when set, x is this
// process's share of a batch split over processes; every statistic (column
// sums and the row count) is summed over the processes through it before it
// is used, so each process normalises with the whole batch's mean / variance.
void batchnorm_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                             const Tensor& y, const Tensor& save_mean, const Tensor& save_invstd,
                             const Tensor& running_mean, const Tensor& running_var, const SumAcross& across = {});
// Evaluation with running statistics.
void batchnorm_eval_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, const Tensor& running_mean,
                            const Tensor& running_var, float eps, const Tensor& y);
// Backward of the training forward; accumulates d_x, d_gamma, d_beta (each may be undefined).
// With `across`, Σdy and Σdy·x̂ (and the row count) are summed over the
// processes for d_x; d_gamma / d_beta stay this process's share (they are
// parameter gradients, summed with all the others after backward).
void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                              const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                              const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across = {});
// Backward of the eval forward (an affine map per column).
void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                             const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                             const Tensor& d_gamma, const Tensor& d_beta);

}  // namespace gatcore::cpu
