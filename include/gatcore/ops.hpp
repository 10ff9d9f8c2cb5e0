#pragma once
// Differentiable ops. Each runs on the Backend of its inputs' device (all
// inputs must live on one device) and records its backward on the current
// tape when gradients are enabled and an input requires them.
//
// `into`: ops that typically end a DenseNet block can write their result
// straight into a preallocated column slice (Var::cols_slice of the dense
// buffer) instead of a fresh tensor; the returned Var is then `into` itself.
// Writing a fresh slot is not an in-place modification of anything saved, so
// it does not bump the buffer's version.
#include <memory>
#include <utility>
#include <vector>

#include "gatcore/activation.hpp"
#include "gatcore/autograd.hpp"
#include "gatcore/graph.hpp"

namespace gatcore {

using GraphPtr = std::shared_ptr<const CsrGraph>;
inline GraphPtr share(CsrGraph g) { return std::make_shared<const CsrGraph>(std::move(g)); }

// Validates model input: one row per graph node and every entry finite.
// Throws InvalidArgument naming `what`, the row and the column of a NaN/Inf.
void check_node_features(const CsrGraph& g, const Tensor& x, const char* what = "node features");

// ---- dense ------------------------------------------------------------------
Var matmul(const Var& a, const Var& b, const Var& into = {});                     // a [n,k] · b [k,m]
Var linear(const Var& x, const Var& W, const Var& b, const Var& into = {});       // x·W + b, W [in,out], b [1,out] or undefined
Var add(const Var& a, const Var& b, const Var& into = {});
Var sub(const Var& a, const Var& b);
Var mul(const Var& a, const Var& b);
Var scale(const Var& a, float s);
Var concat(const std::vector<Var>& parts);  // copies; dense blocks use `into` instead
Var copy_into(const Var& src, const Var& into);  // into = src (e.g. input features into slot 0)

// ---- pointwise ----------------------------------------------------------------
Var activation(Activation f, const Var& x, float slope = 0.01f, const Var& into = {});
inline Var tanh(const Var& x, const Var& into = {}) { return activation(Activation::tanh, x, 0.f, into); }
inline Var tanhshrink(const Var& x, const Var& into = {}) { return activation(Activation::tanhshrink, x, 0.f, into); }
inline Var relu(const Var& x, const Var& into = {}) { return activation(Activation::relu, x, 0.f, into); }
inline Var leaky_relu(const Var& x, float slope = 0.01f, const Var& into = {}) {
  return activation(Activation::leaky_relu, x, slope, into);
}
// Softmax over each row; mask [1, C] (0 = impossible class) may be undefined.
Var row_softmax(const Var& x, const Tensor& mask = {});

// ---- normalisation --------------------------------------------------------------
struct BatchNormState {
  Tensor running_mean, running_var;  // [1, C]
  float momentum = 0.1f;
  float eps = 1e-5f;
};
// Batch statistics (and running-stat update) when training, running stats otherwise.
Var batch_norm(const Var& x, const Var& gamma, const Var& beta, BatchNormState& state, bool training,
               const Var& into = {});
// BatchNorm with batch statistics (training) fused with the activation f
// after it (identity, relu or leaky_relu): the values of
// activation(f, batch_norm(x, ..., true), slope), with one saved tensor (x)
// instead of three: backward recomputes the normalised value and the
// activation's sign from x and the batch statistics. Updates the running
// statistics like batch_norm; SyncBatchNorm under a batch split, likewise.
Var batch_norm_act(const Var& x, const Var& gamma, const Var& beta, BatchNormState& state, Activation f, float slope,
                   const Var& into = {});
// linear(batch_norm_act(x, ...), W, b) without keeping the activation: its
// backward recomputes it from x for W's gradient. A chain of Linear →
// BatchNorm → activation layers built from these keeps one [n, width]
// tensor per layer (the Linear's output) for backward.
Var batch_norm_act_linear(const Var& x, const Var& gamma, const Var& beta, BatchNormState& state, Activation f,
                          float slope, const Var& W, const Var& b);

// ---- graph attention ------------------------------------------------------------
// el/er halves of additive attention: z [n, H*F], a_l/a_r [H, F] -> ([n,H], [n,H]).
std::pair<Var, Var> attention_projection(const Var& z, const Var& a_l, const Var& a_r);
Var edge_softmax_additive(const GraphPtr& g, const Var& el, const Var& er, float slope = 0.2f);  // [E, H]
Var edge_softmax_dot(const GraphPtr& g, const Var& h, int heads, float scale = 1.0f);          // [E, H]
Var aggregate(const GraphPtr& g, const Var& alpha, const Var& z, const Var& into = {});       // [n, H*F]
// Fused multi-head graph attention (logits + softmax + aggregation in one
// pass; stores only alpha). Additive: projections included.
Var gat_additive(const GraphPtr& g, const Var& z, const Var& a_l, const Var& a_r, float slope = 0.2f,
                 const Var& into = {});
Var gat_dot(const GraphPtr& g, const Var& z, int heads, float scale = 1.0f, const Var& into = {});

// ---- pooling ------------------------------------------------------------------------
Var segment_max(const GraphPtr& g, const Var& x);                  // [segments, C] over g->segment_ptr
Var broadcast_segments(const GraphPtr& g, const Var& x);           // [segments, C] -> [n, C]
// x·W + s[segment(i)] (s [segments, out]): a Linear layer whose input is
// x ++ a per-segment feature g, computed as x·W₁ + broadcast(g·W₂) so the
// per-segment product runs once per segment instead of once per row, and the
// concatenation and the broadcast [n, C] tensor are never built.
Var linear_segment_bias(const GraphPtr& g, const Var& x, const Var& W, const Var& s);
Var neighbour_mean(const GraphPtr& nbr, const Var& x, const Var& into = {});  // mean over rows of nbr

// ---- reductions and losses ([1, 1] results) -----------------------------------------------
Var sum(const Var& x);
Var mean(const Var& x);
Var mse_loss(const Var& pred, const Tensor& target);
Var kl_div_loss(const Var& pred, const Tensor& target, float eps = 1e-8f);  // KL(target || pred), mean over rows

}  // namespace gatcore
