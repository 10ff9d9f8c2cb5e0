// Differentiable graph-attention and pooling ops.
#include "src/ops/op_util.hpp"

namespace gatcore {
using namespace ops_detail;

namespace {
void check_graph(const char* op, const GraphPtr& g, std::int64_t rows, const char* what) {
  GATCORE_CHECK(g != nullptr, op, ": graph is null");
  GATCORE_CHECK(rows == g->num_nodes, op, ": ", what, " has ", rows, " rows but the graph has ", g->num_nodes,
                " nodes");
}
// a_l, a_r: [H, F] and z: [n, H*F]; returns H.
int check_attention_vectors(const char* op, const Var& z, const Var& a_l, const Var& a_r) {
  check_var(op, "z", z);
  check_var(op, "a_l", a_l);
  check_var(op, "a_r", a_r);
  const std::int64_t H = a_l.rows();
  GATCORE_CHECK(H >= 1 && a_r.rows() == H && a_r.cols() == a_l.cols() && z.cols() == H * a_l.cols(), op, ": z ",
                z.value().shape_str(), ", a_l ", a_l.value().shape_str(), ", a_r ", a_r.value().shape_str(),
                " do not fit (need a_l, a_r [H, F] and z [n, H*F])");
  return static_cast<int>(H);
}
void check_heads(const char* op, const Var& x, int heads) {
  check_var(op, "input", x);
  GATCORE_CHECK(heads >= 1 && x.cols() % heads == 0, op, ": ", x.cols(), " columns do not split into ", heads,
                " heads");
}
}  // namespace

void check_node_features(const CsrGraph& g, const Tensor& x, const char* what) {
  GATCORE_CHECK(x.defined(), what, ": undefined");
  GATCORE_CHECK(x.rows() == g.num_nodes, what, ": ", x.rows(), " rows for a graph of ", g.num_nodes, " nodes");
  x.device() == Device::cpu ? x.check_finite(what) : to(x, Device::cpu).check_finite(what);
}

std::pair<Var, Var> attention_projection(const Var& z, const Var& a_l, const Var& a_r) {
  static const char* op = "attention_projection";
  check_var(op, "z", z);
  check_var(op, "a_l", a_l);
  check_var(op, "a_r", a_r);
  const int H = check_attention_vectors(op, z, a_l, a_r);
  Backend& be = backend_of(op, {&z, &a_l, &a_r});
  const bool grad = needs_grad({&z, &a_l, &a_r});
  Var el(be.empty(z.rows(), H), grad), er(be.empty(z.rows(), H), grad);
  be.attention_projection_forward(z.value(), a_l.value(), a_r.value(), el.value(), er.value());
  if (grad)
    current_tape().record(op, [&be, zi = z.impl(), li = a_l.impl(), ri = a_r.impl(), eli = el.impl(),
                               eri = er.impl(), zs = SavedTensor(z.value(), "z"),
                               ls = SavedTensor(a_l.value(), "a_l"), rs = SavedTensor(a_r.value(), "a_r")] {
      Tensor del = eli->grad_if_any(), der = eri->grad_if_any();
      if (!del.defined() && !der.defined()) return;
      if (!del.defined()) del = be.zeros(der.rows(), der.cols());
      if (!der.defined()) der = be.zeros(del.rows(), del.cols());
      be.attention_projection_backward(zs.get(op), ls.get(op), rs.get(op), del, der, grad_for(zi), grad_for(li),
                                       grad_for(ri));
    });
  return {el, er};
}

Var edge_softmax_additive(const GraphPtr& g, const Var& el, const Var& er, float slope) {
  static const char* op = "edge_softmax_additive";
  check_var(op, "el", el);
  check_var(op, "er", er);
  check_graph(op, g, el.rows(), "el");
  check_same_shape(op, "el", el.value(), "er", er.value());
  Backend& be = backend_of(op, {&el, &er});
  const bool grad = needs_grad({&el, &er});
  Var alpha(be.empty(g->num_edges(), el.cols()), grad);
  be.edge_softmax_additive_forward(*g, el.value(), er.value(), slope, alpha.value());
  if (grad)
    current_tape().record(op, [&be, g, slope, eli = el.impl(), eri = er.impl(), ai = alpha.impl(),
                               els = SavedTensor(el.value(), "el"), ers = SavedTensor(er.value(), "er"),
                               as = SavedTensor(alpha.value(), "alpha")] {
      Tensor da = ai->grad_if_any();
      if (!da.defined()) return;
      be.edge_softmax_additive_backward(*g, els.get(op), ers.get(op), slope, as.get(op), da, grad_for(eli),
                                        grad_for(eri));
    });
  return alpha;
}

Var edge_softmax_dot(const GraphPtr& g, const Var& h, int heads, float scale) {
  static const char* op = "edge_softmax_dot";
  check_var(op, "h", h);
  check_graph(op, g, h.rows(), "h");
  check_heads(op, h, heads);
  Backend& be = backend_of(op, {&h});
  const bool grad = needs_grad({&h});
  Var alpha(be.empty(g->num_edges(), heads), grad);
  be.edge_softmax_dot_forward(*g, h.value(), heads, scale, alpha.value());
  if (grad)
    current_tape().record(op, [&be, g, heads, scale, hi = h.impl(), ai = alpha.impl(),
                               hs = SavedTensor(h.value(), "h"), as = SavedTensor(alpha.value(), "alpha")] {
      Tensor da = ai->grad_if_any();
      if (!da.defined()) return;
      be.edge_softmax_dot_backward(*g, hs.get(op), heads, scale, as.get(op), da, grad_for(hi));
    });
  return alpha;
}

Var aggregate(const GraphPtr& g, const Var& alpha, const Var& z, const Var& into) {
  static const char* op = "aggregate";
  check_var(op, "alpha", alpha);
  check_var(op, "z", z);
  check_graph(op, g, z.rows(), "z");
  GATCORE_CHECK(alpha.rows() == g->num_edges() && alpha.cols() >= 1 && z.cols() % alpha.cols() == 0, op,
                ": alpha ", alpha.value().shape_str(), " must be [E=", g->num_edges(),
                ", H] with H dividing z's ", z.cols(), " columns");
  Backend& be = backend_of(op, {&alpha, &z});
  const bool grad = needs_grad({&alpha, &z});
  Var y = make_output(op, be, z.rows(), z.cols(), into, grad);
  be.aggregate_forward(*g, alpha.value(), z.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, g, ai = alpha.impl(), zi = z.impl(), yi = y.impl(),
                               as = SavedTensor(alpha.value(), "alpha"), zs = SavedTensor(z.value(), "z")] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      // One pass computes both gradients; d_alpha is overwritten by the
      // kernel, so it goes through overwrite_grad_into when alpha wants one.
      const Tensor dz = grad_for(zi);
      if (ai->requires_grad)
        overwrite_grad_into(be, ai, [&](const Tensor& d_alpha) {
          be.aggregate_backward(*g, as.get(op), zs.get(op), dy, d_alpha, dz);
        });
      else if (dz.defined())
        be.aggregate_backward(*g, as.get(op), zs.get(op), dy, Tensor{}, dz);
    });
  return y;
}

Var gat_additive(const GraphPtr& g, const Var& z, const Var& a_l, const Var& a_r, float slope, const Var& into) {
  static const char* op = "gat_additive";
  check_var(op, "z", z);
  check_var(op, "a_l", a_l);
  check_var(op, "a_r", a_r);
  check_graph(op, g, z.rows(), "z");
  const int H = check_attention_vectors(op, z, a_l, a_r);
  Backend& be = backend_of(op, {&z, &a_l, &a_r});
  const bool grad = needs_grad({&z, &a_l, &a_r});
  Tensor el = be.empty(z.rows(), H), er = be.empty(z.rows(), H);
  be.attention_projection_forward(z.value(), a_l.value(), a_r.value(), el, er);
  Var y = make_output(op, be, z.rows(), z.cols(), into, grad);
  // alpha is only needed for backward; inference writes it to a scratch that dies here.
  Tensor alpha = be.empty(g->num_edges(), H);
  be.gat_fused_additive_forward(*g, z.value(), el, er, slope, y.value(), alpha);
  if (grad)
    current_tape().record(op, [&be, g, slope, zi = z.impl(), li = a_l.impl(), ri = a_r.impl(), yi = y.impl(),
                               zs = SavedTensor(z.value(), "z"), ls = SavedTensor(a_l.value(), "a_l"),
                               rs = SavedTensor(a_r.value(), "a_r"), el, er, alpha] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      const Tensor& zv = zs.get(op);
      Tensor del = be.zeros(el.rows(), el.cols()), der = be.zeros(er.rows(), er.cols());
      Tensor dz = grad_for(zi);
      be.gat_fused_additive_backward(*g, zv, el, er, slope, alpha, dy, dz, del, der);
      be.attention_projection_backward(zv, ls.get(op), rs.get(op), del, der, dz, grad_for(li), grad_for(ri));
    });
  return y;
}

Var gat_dot(const GraphPtr& g, const Var& z, int heads, float scale, const Var& into) {
  static const char* op = "gat_dot";
  check_var(op, "z", z);
  check_graph(op, g, z.rows(), "z");
  check_heads(op, z, heads);
  Backend& be = backend_of(op, {&z});
  const bool grad = needs_grad({&z});
  Var y = make_output(op, be, z.rows(), z.cols(), into, grad);
  Tensor alpha = be.empty(g->num_edges(), heads);
  be.gat_fused_dot_forward(*g, z.value(), heads, scale, y.value(), alpha);
  if (grad)
    current_tape().record(op, [&be, g, heads, scale, zi = z.impl(), yi = y.impl(), zs = SavedTensor(z.value(), "z"),
                               alpha] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.gat_fused_dot_backward(*g, zs.get(op), heads, scale, alpha, dy, zi->grad_or_zeros());
    });
  return y;
}

Var segment_max(const GraphPtr& g, const Var& x) {
  static const char* op = "segment_max";
  check_var(op, "x", x);
  check_graph(op, g, x.rows(), "x");
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y(be.empty(g->num_segments(), x.cols()), grad);
  Tensor argmax = be.empty(g->num_segments(), x.cols(), DType::i32);
  be.segment_max_forward(x.value(), g->segment_ptr, y.value(), argmax);
  if (grad)
    current_tape().record(op, [&be, xi = x.impl(), yi = y.impl(), argmax] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.segment_max_backward(dy, argmax, xi->grad_or_zeros());
    });
  return y;
}

Var broadcast_segments(const GraphPtr& g, const Var& x) {
  static const char* op = "broadcast_segments";
  check_var(op, "x", x);
  GATCORE_CHECK(g != nullptr, op, ": graph is null");
  GATCORE_CHECK(x.rows() == g->num_segments(), op, ": x has ", x.rows(), " rows but the graph has ",
                g->num_segments(), " segments");
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y(be.empty(g->num_nodes, x.cols()), grad);
  be.broadcast_segments_forward(x.value(), g->segment_ptr, y.value());
  if (grad)
    current_tape().record(op, [&be, g, xi = x.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.broadcast_segments_backward(dy, g->segment_ptr, xi->grad_or_zeros());
    });
  return y;
}

Var linear_segment_bias(const GraphPtr& g, const Var& x, const Var& W, const Var& s) {
  static const char* op = "linear_segment_bias";
  check_var(op, "x", x);
  check_var(op, "W", W);
  check_var(op, "s", s);
  check_graph(op, g, x.rows(), "x");
  GATCORE_CHECK(x.cols() == W.rows(), op, ": x ", x.value().shape_str(), " does not match W ",
                W.value().shape_str(), " (x.cols must equal W.rows)");
  GATCORE_CHECK(s.rows() == g->num_segments() && s.cols() == W.cols(), op, ": s ", s.value().shape_str(),
                " must be [", g->num_segments(), " segments, ", W.cols(), "]");
  Backend& be = backend_of(op, {&x, &W, &s});
  const bool grad = needs_grad({&x, &W, &s});
  Var y(be.empty(x.rows(), W.cols()), grad);
  // y = s[segment(i)], then y += x W: one pass over y besides the product.
  be.broadcast_segments_forward(s.value(), g->segment_ptr, y.value());
  const Precision prec = product_precision(be, x.cols());
  product(be, prec, x.value(), false, W.value(), false, y.value(), 1.0f, 1.0f);
  if (grad)
    current_tape().record(op, [&be, prec, g, xi = x.impl(), Wi = W.impl(), si = s.impl(), yi = y.impl(),
                               xs = SavedTensor(x.value(), "x"), Ws = SavedTensor(W.value(), "W")] {
      Tensor dy = yi->grad_if_any();
      if (!dy.defined()) return;
      accumulate_grad(be, xi, [&](const Tensor& dx, float beta) {
        product(be, prec, dy, false, Ws.get(op), true, dx, 1.0f, beta);
      });
      accumulate_grad(be, Wi, [&](const Tensor& dW, float beta) {
        product(be, prec, xs.get(op), true, dy, false, dW, 1.0f, beta);
      });
      if (si->requires_grad) be.broadcast_segments_backward(dy, g->segment_ptr, si->grad_or_zeros());
    });
  return y;
}

Var neighbour_mean(const GraphPtr& nbr, const Var& x, const Var& into) {
  static const char* op = "neighbour_mean";
  check_var(op, "x", x);
  check_graph(op, nbr, x.rows(), "x");
  Backend& be = backend_of(op, {&x});
  const bool grad = needs_grad({&x});
  Var y = make_output(op, be, x.rows(), x.cols(), into, grad);
  be.neighbour_mean_forward(*nbr, x.value(), y.value());
  if (grad)
    current_tape().record(op, [&be, nbr, xi = x.impl(), yi = y.impl()] {
      Tensor dy = yi->grad_if_any();
      if (dy.defined()) be.neighbour_mean_backward(*nbr, dy, xi->grad_or_zeros());
    });
  return y;
}

}  // namespace gatcore
