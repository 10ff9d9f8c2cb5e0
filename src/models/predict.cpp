#include "gatcore/models/predict.hpp"
#include "gatcore/backend.hpp"
#include "gatcore/vulkan.hpp"

#include <algorithm>
#include <numeric>

namespace gatcore::models {

std::vector<std::vector<std::int32_t>> hop_neighbours(const CsrGraph& g, int k) {
  const std::int64_t n = g.num_nodes;
  std::vector<std::vector<std::int32_t>> out(static_cast<std::size_t>(n));
  std::vector<std::int64_t> seen(std::size_t(n), -1);
#pragma omp parallel for schedule(dynamic, 64) firstprivate(seen)
  for (std::int64_t s = 0; s < n; ++s) {
    auto& lst = out[std::size_t(s)];
    lst.push_back(std::int32_t(s));
    seen[std::size_t(s)] = s;
    for (std::size_t head = 0; head < lst.size() && std::int64_t(lst.size()) < k; ++head) {
      const std::int32_t u = lst[head];
      for (std::int64_t e = g.indptr[u]; e < g.indptr[u + 1] && std::int64_t(lst.size()) < k; ++e) {
        const std::int32_t w = g.indices[std::size_t(e)];
        if (seen[std::size_t(w)] == s) continue;
        seen[std::size_t(w)] = s;
        lst.push_back(w);
      }
    }
  }
  return out;
}

namespace {

Tensor gather_rows(const Tensor& t, const std::vector<std::int32_t>& rows, Tensor out, std::int64_t r0) {
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const float* src = t.row(rows[k]);
    float* dst = out.row(r0 + std::int64_t(k));
    std::copy(src, src + t.cols(), dst);
  }
  return out;
}

}  // namespace

Batch make_batch(const std::vector<const Sample*>& samples, const std::vector<std::vector<std::int32_t>>& selections,
                 const Normaliser& norm, const std::vector<int>& pool_sizes) {
  GATCORE_CHECK(!samples.empty() && samples.size() == selections.size(), "make_batch: ", samples.size(),
                " samples but ", selections.size(), " selections");
  std::vector<CsrGraph> subs(samples.size());
  std::vector<std::vector<std::int32_t>> sel(samples.size());
  std::int64_t total = 0;
  const std::int64_t d = samples[0]->features.cols();
  const bool has_target = samples[0]->target.defined();
  const std::int64_t tc = has_target ? samples[0]->target.cols() : 0;
  bool any_mask = false;
  const bool has_prior = samples[0]->prior.defined();
  for (std::size_t b = 0; b < samples.size(); ++b) {
    const Sample& s = *samples[b];
    GATCORE_CHECK(s.graph != nullptr, "sample '", s.name, "': no graph");
    const std::int64_t n = s.graph->num_nodes;
    check_shape(s.features, n, d, ("features of sample '" + s.name + "'").c_str());
    if (has_target) check_shape(s.target, n, tc, ("target of sample '" + s.name + "'").c_str());
    GATCORE_CHECK(s.prior.defined() == has_prior, "make_batch: sample '", s.name, "' ",
                  has_prior ? "has no prior, " : "has a prior, ", "sample '", samples[0]->name, "' ",
                  has_prior ? "has one" : "has none");
    if (has_prior)
      check_shape(s.prior, n, samples[0]->prior.cols(), ("prior of sample '" + s.name + "'").c_str());
    sel[b] = selections[b];
    if (sel[b].empty()) {
      sel[b].resize(std::size_t(n));
      std::iota(sel[b].begin(), sel[b].end(), 0);
      subs[b] = *s.graph;
    } else {
      subs[b] = induced_subgraph(*s.graph, sel[b]);
    }
    total += std::int64_t(sel[b].size());
    any_mask = any_mask || s.bone_mask.defined();
  }
  Batch out;
  std::vector<const CsrGraph*> ptrs;
  for (auto& g : subs) ptrs.push_back(&g);
  out.graph = samples.size() == 1 ? share(subs[0]) : share(batch_graphs(ptrs));
  Tensor raw = Tensor::empty(total, d);
  if (has_target) out.target = Tensor::empty(total, tc);
  if (has_prior) out.prior = Tensor::empty(total, samples[0]->prior.cols());
  std::int64_t r0 = 0;
  for (std::size_t b = 0; b < samples.size(); ++b) {
    gather_rows(samples[b]->features, sel[b], raw, r0);
    if (has_target) gather_rows(samples[b]->target, sel[b], out.target, r0);
    if (has_prior) gather_rows(samples[b]->prior, sel[b], out.prior, r0);
    r0 += std::int64_t(sel[b].size());
  }
  out.x = norm.defined() ? norm.apply(raw) : raw;
  if (has_target && norm.target_scale != 1.f)
    for (std::int64_t i = 0; i < total; ++i)
      for (std::int64_t j = 0; j < tc; ++j) out.target.at(i, j) *= norm.target_scale;
  check_node_features(*out.graph, out.x, "batch features");

  if (any_mask) {
    // One [1, B] mask if all agree, else per-row [n, B].
    const std::int64_t B = tc > 0 ? tc : samples[0]->bone_mask.cols();
    bool uniform = true;
    for (std::size_t b = 1; b < samples.size(); ++b) {
      const Tensor &m0 = samples[0]->bone_mask, &mb = samples[b]->bone_mask;
      if (!m0.defined() || !mb.defined() || m0.to_vector() != mb.to_vector()) uniform = false;
    }
    if (uniform) {
      out.mask = samples[0]->bone_mask.clone();
    } else {
      out.mask = Tensor::full(total, B, 1.f);
      r0 = 0;
      for (std::size_t b = 0; b < samples.size(); ++b) {
        const Tensor& m = samples[b]->bone_mask;
        for (std::size_t i = 0; i < sel[b].size(); ++i)
          for (std::int64_t j = 0; j < B && m.defined(); ++j) out.mask.at(r0 + std::int64_t(i), j) = m.at(0, j);
        r0 += std::int64_t(sel[b].size());
      }
    }
  }

  if (!pool_sizes.empty()) {
    const int kmax = *std::max_element(pool_sizes.begin(), pool_sizes.end());
    // Per sample: neighbour lists in local (selection) ids, nearest first.
    std::vector<std::vector<std::vector<std::int32_t>>> local(samples.size());
    for (std::size_t b = 0; b < samples.size(); ++b) {
      const Sample& s = *samples[b];
      if (s.geodesic_neighbours.empty()) {
        local[b] = hop_neighbours(subs[b], kmax);
        continue;
      }
      GATCORE_CHECK(std::int64_t(s.geodesic_neighbours.size()) == s.graph->num_nodes, "sample '", s.name,
                    "': geodesic_neighbours has ", s.geodesic_neighbours.size(), " rows, the mesh ",
                    s.graph->num_nodes, " vertices");
      std::vector<std::int32_t> to_local(std::size_t(s.graph->num_nodes), -1);
      for (std::size_t i = 0; i < sel[b].size(); ++i) to_local[std::size_t(sel[b][i])] = std::int32_t(i);
      local[b].resize(sel[b].size());
      for (std::size_t i = 0; i < sel[b].size(); ++i) {
        for (std::int32_t v : s.geodesic_neighbours[std::size_t(sel[b][i])]) {
          if (std::int64_t(local[b][i].size()) >= kmax) break;
          if (to_local[std::size_t(v)] >= 0) local[b][i].push_back(to_local[std::size_t(v)]);
        }
        if (local[b][i].empty()) local[b][i].push_back(std::int32_t(i));
      }
    }
    for (int J : pool_sizes) {
      if (out.neighbours.count(J)) continue;
      std::vector<std::vector<std::int32_t>> rows;
      rows.reserve(std::size_t(total));
      std::int32_t off = 0;
      for (std::size_t b = 0; b < samples.size(); ++b) {
        for (const auto& lst : local[b]) {
          std::vector<std::int32_t> r;
          for (std::size_t t = 0; t < lst.size() && int(t) < J; ++t) r.push_back(lst[t] + off);
          rows.push_back(std::move(r));
        }
        off += std::int32_t(sel[b].size());
      }
      out.neighbours[J] = share(graph_from_neighbour_lists(total, rows));
    }
  }
  return out;
}

void to_device(Batch& b, Device d) {
  if (b.x.defined()) b.x = to(b.x, d);
  if (b.target.defined()) b.target = to(b.target, d);
  if (b.mask.defined()) b.mask = to(b.mask, d);
  if (b.prior.defined()) b.prior = to(b.prior, d);
}

void forget_graphs(const Batch& b, Device d) {
  if (d != Device::vulkan) return;
  if (b.graph) vulkan::forget_graph(b.graph.get());
  for (const auto& kv : b.neighbours)
    if (kv.second) vulkan::forget_graph(kv.second.get());
}

Tensor predict(Model& model, const Sample& s, const Normaliser& norm, int top_k) {
  NoGradGuard ng;
  Sample copy = s;
  copy.target = Tensor{};
  Batch b = make_batch({&copy}, {{}}, norm, model.pool_sizes());
  to_device(b, model.device());
  Tensor y = to(model.forward(b, false).value(), Device::cpu).clone();
  forget_graphs(b, model.device());
  if (model.config().task == Task::displacement) {
    if (norm.target_scale != 1.f)
      for (std::int64_t i = 0; i < y.rows(); ++i)
        for (std::int64_t j = 0; j < y.cols(); ++j) y.at(i, j) /= norm.target_scale;
    return y;
  }
  return top_k > 0 ? top_k_renormalise(y, top_k) : y;
}

}  // namespace gatcore::models
