#pragma once
// BatchNorm1d over the rows (nodes) of x: [n, C]. Statistics in double
// precision for stability on 10^5 rows. gamma / beta may be undefined (no
// affine part); training needs at least 2 rows.
#include "gatcore/activation.hpp"
#include "gatcore/batch_split.hpp"
#include "gatcore/tensor.hpp"
#include "src/backends/cpu/inference.hpp"

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
// accumulate_dx = false writes d_x instead (its contents ignored, NaN
// included): the bits of accumulating onto zeros, without the zero fill.
void batchnorm_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& save_mean,
                              const Tensor& save_invstd, const Tensor& d_y, const Tensor& d_x,
                              const Tensor& d_gamma, const Tensor& d_beta, const SumAcross& across = {},
                              bool accumulate_dx = true);
// Backward of the eval forward (an affine map per column).
void batchnorm_eval_backward(const Tensor& x, const Tensor& gamma, const Tensor& running_mean,
                             const Tensor& running_var, float eps, const Tensor& d_y, const Tensor& d_x,
                             const Tensor& d_gamma, const Tensor& d_beta);


// BatchNorm (training) fused with the activation f that follows it (identity,
// relu or leaky_relu with `slope`): y = f(BatchNorm(x)) in one pass after the
// statistics, the same values as batchnorm_train_forward then
// activation_forward. Saves what backward needs to recompute the normalised
// value and the activation's sign from x instead of keeping them: save_mean /
// save_invstd [1, C] (as batchnorm_train_forward's) and save_affine [2, C]
// (the low part of the mean, gamma·invstd as rounded for the forward).
void batchnorm_act_train_forward(const Tensor& x, const Tensor& gamma, const Tensor& beta, float eps, float momentum,
                                 Activation f, float slope, const Tensor& y, const Tensor& save_mean,
                                 const Tensor& save_invstd, const Tensor& save_affine, const Tensor& running_mean,
                                 const Tensor& running_var, const SumAcross& across = {});
// y = f(BatchNorm(x)) again from the saved statistics: the forward's values
// bit for bit (a backward that needs the activation output recomputes it).
void batchnorm_act_apply(const Tensor& x, const Tensor& beta, Activation f, float slope, const Tensor& save_mean,
                         const Tensor& save_affine, const Tensor& y);
// Backward of the fused forward from x, the saved statistics and d_y (the
// gradient of f's output); accumulates d_x, d_gamma, d_beta (each may be
// undefined). The same values as activation_backward then
// batchnorm_train_backward; `across` and accumulate_dx as there.
void batchnorm_act_train_backward(const Tensor& x, const Tensor& gamma, const Tensor& beta, Activation f, float slope,
                                  const Tensor& save_mean, const Tensor& save_invstd, const Tensor& save_affine,
                                  const Tensor& d_y, const Tensor& d_x, const Tensor& d_gamma, const Tensor& d_beta,
                                  const SumAcross& across = {}, bool accumulate_dx = true);

}  // namespace gatcore::cpu
