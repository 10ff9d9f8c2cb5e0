// docs/library.md, "Ops and autodiff": one multi-head graph-attention layer
// on a small mesh, trained with Adam for a few steps. Built and run by the
// ctest docs_example_autodiff; exits non-zero unless the loss falls.
#include <cstdio>
#include <vector>

#include "gatcore/ops.hpp"
#include "gatcore/optim.hpp"

int main() {
  using namespace gatcore;
  // A 4 x 4 grid of vertices, two triangles per cell.
  const int side = 4, n = side * side;
  std::vector<std::int32_t> triangles;
  for (int r = 0; r + 1 < side; ++r)
    for (int c = 0; c + 1 < side; ++c) {
      int v = r * side + c;
      triangles.insert(triangles.end(), {v, v + 1, v + side, v + 1, v + side + 1, v + side});
    }
  GraphPtr g = share(graph_from_triangles(n, triangles));  // mesh edges + self-loops

  std::vector<float> xs, ts;
  for (int i = 0; i < n; ++i) {
    xs.insert(xs.end(), {float(i % side) / side, float(i / side) / side, 1.0f});
    ts.push_back(float(i % side + i / side) / (2 * side));
  }
  Var x(Tensor::from(n, 3, xs));  // node features [n, d], no gradient
  Tensor target = Tensor::from(n, 1, ts);

  const int heads = 2, features = 4;
  Var W = Var::parameter(Tensor::full(3, heads * features, 0.1f), "W");
  Var a_dst = Var::parameter(Tensor::full(heads, features, 0.1f), "att_dst");
  Var a_src = Var::parameter(Tensor::full(heads, features, -0.1f), "att_src");
  Var head = Var::parameter(Tensor::full(heads * features, 1, 0.05f), "head");
  Adam adam({W, a_dst, a_src, head}, AdamOptions{.lr = 1e-2f});

  float first = 0, last = 0;
  for (int step = 0; step < 50; ++step) {
    Var h = tanhshrink(gat_additive(g, linear(x, W, Var{}), a_dst, a_src));  // [n, heads * features]
    Var loss = mse_loss(matmul(h, head), target);
    adam.zero_grad();
    backward(loss);  // fills W.grad(), a_dst.grad(), a_src.grad(), head.grad()
    adam.step();
    last = loss.value().at(0, 0);
    if (step == 0) first = last;
  }
  std::printf("loss %.5f -> %.5f after 50 Adam steps\n", first, last);
  return last < 0.5f * first ? 0 : 1;
}
