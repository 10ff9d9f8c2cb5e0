#include "gatcore/character/features/bone_candidates.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/features/frame_features.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::int64_t bone_candidate_feature_dim(int k) { return kVertexColumns + static_cast<std::int64_t>(k) * kPairFeatures; }

BoneHeatParams prior_bone_heat(const models::ModelConfig& cfg) {
  BoneHeatParams hp;
  hp.max_influences = 64;
  hp.min_weight = 0.0f;
  if (!cfg.prior_weight_limit) hp.cut_below = 0.0f;
  if (!cfg.prior_straight_chains) hp.continue_cos = 2.0f;
  return hp;
}

BoneCandidates bone_candidate_features(const PreparedCharacter& pc, int k, const BoneHeatParams& heat) {
  const Character& ch = pc.character;
  const Skeleton& sk = ch.skeleton;
  const std::int32_t nj = sk.num_joints();
  GATCORE_CHECK(k >= 1 && k <= 64, ch.name, ": bone candidates per vertex must be in [1, 64], got ", k);
  GATCORE_CHECK(nj > 0, ch.name, ": bone candidates need a skeleton with joints");
  const std::int64_t n = ch.mesh.num_vertices();
  BoneCandidates out;
  out.k = k;
  out.valid = std::min(k, nj);
  out.joint.assign(static_cast<std::size_t>(n * k), -1);
  const std::int64_t dim = bone_candidate_feature_dim(k);
  out.features = Tensor::zeros(n, dim);
  // Position and normal columns: NeuroSkinning's first six.
  const Tensor base = neuroskinning_rest_features(pc, all_vertices(n));
  const std::vector<float> rest = apply_normalisation(pc.normalisation, ch.mesh.positions);
  // Segments in the normalised frame.
  const auto segs = bone_segments(sk, heat);
  std::vector<std::vector<std::pair<Vec3, Vec3>>> seg(static_cast<std::size_t>(nj));
  for (std::int32_t j = 0; j < nj; ++j)
    for (const auto& s : segs[j]) seg[j].push_back({apply_normalisation(pc.normalisation, s.a), apply_normalisation(pc.normalisation, s.b)});
  std::vector<int> depth(static_cast<std::size_t>(nj), 0);
  int max_depth = 1;
  for (std::int32_t j = 0; j < nj; ++j) {
    if (sk.parents[j] >= 0) depth[j] = depth[sk.parents[j]] + 1;
    max_depth = std::max(max_depth, depth[j]);
  }
  const auto children = sk.children();
  // Bone heat's weights as a classical prior per candidate: the network
  // learns the corrections to it.
  const SkinWeights prior = bone_heat_weights(ch, heat);
  std::vector<float> heat_row(static_cast<std::size_t>(nj), 0.0f);
  struct Near {
    float d, along, perp, dy, len, t;
  };
  std::vector<Near> near(static_cast<std::size_t>(nj));
  std::vector<std::pair<float, std::int32_t>> order(static_cast<std::size_t>(nj));
  for (std::int64_t v = 0; v < n; ++v) {
    float* row = out.features.data() + v * dim;
    for (int c = 0; c < kVertexColumns; ++c) row[c] = base.at(v, c);
    const float x[3] = {rest[3 * v], rest[3 * v + 1], rest[3 * v + 2]};
    for (std::int64_t e = prior.ptr[v]; e < prior.ptr[v + 1]; ++e) heat_row[prior.joint[e]] = prior.weight[e];
    for (std::int32_t j = 0; j < nj; ++j) {
      Near best{1e30f, 0, 0, 0, 0, 0};
      for (const auto& [a, b] : seg[j]) {
        float ab[3], ax[3];
        double l2 = 0, proj = 0;
        for (int c = 0; c < 3; ++c) {
          ab[c] = b[c] - a[c];
          ax[c] = x[c] - a[c];
          l2 += double(ab[c]) * ab[c];
          proj += double(ab[c]) * ax[c];
        }
        const double len = std::sqrt(l2);
        const double t = l2 > 0 ? std::clamp(proj / l2, 0.0, 1.0) : 0.0;
        double d2 = 0, dy = 0;
        for (int c = 0; c < 3; ++c) {
          const double q = a[c] + t * ab[c];
          d2 += (x[c] - q) * (x[c] - q);
          if (c == 1) dy = x[c] - q;
        }
        const double along = len > 0 ? proj / len : 0.0;
        double perp2 = 0;
        for (int c = 0; c < 3; ++c) {
          const double r = ax[c] - (len > 0 ? along * ab[c] / len : 0.0);
          perp2 += r * r;
        }
        const float d = static_cast<float>(std::sqrt(d2));
        if (d < best.d)
          best = {d, float(along), float(std::sqrt(perp2)), float(dy), float(len), float(t)};
      }
      near[j] = best;
      order[j] = {best.d, j};
    }
    std::partial_sort(order.begin(), order.begin() + out.valid, order.end());
    const float d0 = order[0].first;
    for (int c = 0; c < out.valid; ++c) {
      const std::int32_t j = order[c].second;
      out.joint[static_cast<std::size_t>(v * k + c)] = j;
      const Near& e = near[j];
      float* f = row + kVertexColumns + c * kPairFeatures;
      f[0] = e.d;
      f[1] = e.d - d0;
      f[2] = e.along;
      f[3] = e.perp;
      f[4] = e.dy;
      f[5] = e.len;
      f[6] = e.t;
      f[7] = float(depth[j]) / float(max_depth);
      f[8] = children[j].empty() ? 1.0f : 0.0f;
      f[kBoneHeatPairColumn] = heat_row[j];
    }
    for (std::int64_t e = prior.ptr[v]; e < prior.ptr[v + 1]; ++e) heat_row[prior.joint[e]] = 0.0f;
  }
  return out;
}

Tensor bone_heat_log_prior(const BoneCandidates& c, float eps) {
  GATCORE_CHECK(eps > 0.0f && std::isfinite(eps), "bone_heat_log_prior: eps must be positive, got ", eps);
  const std::int64_t n = c.features.rows();
  GATCORE_CHECK(c.features.cols() == bone_candidate_feature_dim(c.k), "bone_heat_log_prior: ", c.features.cols(),
                " feature columns for ", c.k, " candidates");
  Tensor p = Tensor::zeros(n, c.k);
  for (std::int64_t v = 0; v < n; ++v)
    for (int i = 0; i < c.valid; ++i) {
      const float h = c.features.at(v, kVertexColumns + std::int64_t(i) * kPairFeatures + kBoneHeatPairColumn);
      GATCORE_CHECK(std::isfinite(h) && h >= 0.0f, "bone_heat_log_prior: bone heat weight ", h, " at vertex ", v);
      p.at(v, i) = std::log(h + eps);
    }
  return p;
}

namespace {

void check_candidate_rows(const char* what, const BoneCandidates& c, const SkinWeights& w) {
  GATCORE_CHECK(static_cast<std::int64_t>(c.joint.size()) == w.num_vertices() * c.k, what, ": ",
                c.joint.size() / std::max(1, c.k), " candidate rows for ", w.num_vertices(), " weight rows");
}

// The artist's weight of vertex v on its candidate i (the candidate joint's
// entries of the row summed).
float candidate_weight(const BoneCandidates& c, const SkinWeights& w, std::int64_t v, int i) {
  const std::int32_t j = c.joint[static_cast<std::size_t>(v * c.k + i)];
  float x = 0.0f;
  for (std::int64_t e = w.ptr[v]; e < w.ptr[v + 1]; ++e)
    if (w.joint[e] == j) x += w.weight[e];
  return x;
}

}  // namespace

Tensor candidate_targets(const BoneCandidates& c, const SkinWeights& w) {
  check_candidate_rows("candidate_targets", c, w);
  const std::int64_t n = w.num_vertices();
  Tensor t = Tensor::zeros(n, c.k);
  for (std::int64_t v = 0; v < n; ++v) {
    double s = 0;
    for (int i = 0; i < c.valid; ++i) s += t.at(v, i) = candidate_weight(c, w, v, i);
    if (s > 0)
      for (int i = 0; i < c.valid; ++i) t.at(v, i) = static_cast<float>(t.at(v, i) / s);
    else
      t.at(v, 0) = 1.0f;
  }
  return t;
}

Tensor candidate_target_mass(const BoneCandidates& c, const SkinWeights& w) {
  check_candidate_rows("candidate_target_mass", c, w);
  const std::int64_t n = w.num_vertices();
  Tensor m = Tensor::zeros(n, 1);
  for (std::int64_t v = 0; v < n; ++v) {
    double total = 0, held = 0;
    for (std::int64_t e = w.ptr[v]; e < w.ptr[v + 1]; ++e) total += w.weight[e];
    for (int i = 0; i < c.valid; ++i) held += candidate_weight(c, w, v, i);
    m.at(v, 0) = total > 0 ? static_cast<float>(held / total) : 1.0f;
  }
  return m;
}

std::vector<std::int32_t> candidate_target_dominant(const BoneCandidates& c, const SkinWeights& w) {
  check_candidate_rows("candidate_target_dominant", c, w);
  const std::int64_t n = w.num_vertices();
  std::vector<std::int32_t> out(static_cast<std::size_t>(n), -1);
  std::vector<std::pair<std::int32_t, double>> row;
  for (std::int64_t v = 0; v < n; ++v) {
    row.clear();  // weights per joint (a joint may appear twice in a row)
    for (std::int64_t e = w.ptr[v]; e < w.ptr[v + 1]; ++e) {
      auto it = std::find_if(row.begin(), row.end(), [&](const auto& x) { return x.first == w.joint[e]; });
      if (it == row.end()) row.push_back({w.joint[e], w.weight[e]});
      else it->second += w.weight[e];
    }
    if (row.empty()) continue;
    std::pair<std::int32_t, double> best = row.front();
    for (const auto& x : row)
      if (x.second > best.second || (x.second == best.second && x.first < best.first)) best = x;
    for (int i = 0; i < c.valid; ++i)
      if (c.joint[static_cast<std::size_t>(v * c.k + i)] == best.first) out[static_cast<std::size_t>(v)] = i;
  }
  return out;
}

SkinWeights weights_from_candidates(const BoneCandidates& c, const Tensor& p) {
  const std::int64_t n = static_cast<std::int64_t>(c.joint.size()) / std::max(1, c.k);
  GATCORE_CHECK(p.rows() == n && p.cols() == c.k, "weights_from_candidates: ", p.rows(), " x ", p.cols(),
                " probabilities for ", n, " vertices x ", c.k, " candidates");
  SkinWeights w;
  std::vector<std::pair<std::int32_t, float>> row;
  for (std::int64_t v = 0; v < n; ++v) {
    row.clear();
    double s = 0;
    for (int i = 0; i < c.valid; ++i) {
      const float x = p.at(v, i);
      GATCORE_CHECK(std::isfinite(x), "weights_from_candidates: non-finite probability at vertex ", v);
      if (x > 0) row.push_back({c.joint[static_cast<std::size_t>(v * c.k + i)], x}), s += x;
    }
    if (s <= 0) row = {{c.joint[static_cast<std::size_t>(v * c.k)], 1.0f}}, s = 1.0;
    std::sort(row.begin(), row.end());
    for (const auto& [j, x] : row) {
      w.joint.push_back(j);
      w.weight.push_back(static_cast<float>(x / s));
    }
    w.ptr.push_back(static_cast<std::int64_t>(w.joint.size()));
  }
  return w;
}

}  // namespace gatcore::character
