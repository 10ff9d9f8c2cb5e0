// gatcore's bone heat beside Blender's automatic weights, scored the same way.
//
//   bone_heat_peer CHARACTER.glb BLENDER.json [--json OUT.json]
//     reads what tests/blender/auto_weights.py wrote for CHARACTER.glb, matches
//     Blender's vertices to gatcore's welded ones by position, and prints one
//     line: L1 / dominant bone of gatcore's bone heat and of Blender's, against
//     the artist's weights, over the file's own joints, both cut the same way
//     (top 4, influences under 0.01 dropped, renormalised). Blender's artist
//     weights read through the same match must equal gatcore's import of the
//     file (the match is checked, not assumed): exit 1 otherwise.
//   bone_heat_peer --procedural humanoid|creature SEED OUT.glb
//     writes a procedural character (for the peer run without shared data).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "gatcore/character/data/procedural.hpp"
#include "gatcore/character/deform/bone_heat.hpp"
#include "gatcore/character/eval/boundaries.hpp"
#include "gatcore/character/eval/metrics.hpp"
#include "gatcore/character/eval/weight_eval.hpp"
#include "gatcore/character/io/gltf.hpp"
#include "gatcore/character/io/import.hpp"
#include "gatcore/character/rig/limit_weights.hpp"
#include "gatcore/error.hpp"

using namespace gatcore;
using namespace gatcore::character;

namespace {

struct Score {
  double l1 = 0, dominant = 0;
};

Score score(const std::vector<float>& pred, const std::vector<float>& truth, std::int64_t nj,
            const std::vector<std::uint8_t>& rows) {
  // Over the rows selected by `rows` (all when empty).
  std::vector<float> p, t;
  const std::int64_t n = static_cast<std::int64_t>(truth.size()) / nj;
  for (std::int64_t v = 0; v < n; ++v) {
    if (!rows.empty() && !rows[static_cast<std::size_t>(v)]) continue;
    p.insert(p.end(), pred.begin() + v * nj, pred.begin() + (v + 1) * nj);
    t.insert(t.end(), truth.begin() + v * nj, truth.begin() + (v + 1) * nj);
  }
  if (t.empty()) return {};
  return {weight_metrics(p, t, nj).l1_mean, dominant_accuracy(p, t, nj)};
}

int run(const std::string& glb, const std::string& json_in, const std::string& json_out, const BoneHeatParams& bp,
        int confusions) {
  const Character ch = load_character(glb);
  const std::int32_t nj = ch.skeleton.num_joints();
  const std::int64_t n = ch.mesh.num_vertices();
  std::ifstream f(json_in);
  if (!f) {
    std::fprintf(stderr, "bone_heat_peer: cannot read %s\n", json_in.c_str());
    return 2;
  }
  const nlohmann::json doc = nlohmann::json::parse(f);
  const auto& bones = doc.at("bones");
  std::vector<std::int32_t> bone_joint;
  std::int32_t unnamed = 0;
  for (const auto& b : bones) {
    bone_joint.push_back(ch.skeleton.find(b.get<std::string>()));
    unnamed += bone_joint.back() < 0;
  }
  // Blender's frame -> gatcore's bind frame: the similarity taking Blender's
  // bone heads to the joints' bind positions (least squares, Umeyama).
  const auto& heads = doc.at("heads");
  GATCORE_CHECK(heads.size() == 3 * bones.size(), json_in, ": ", heads.size() / 3, " bone heads for ", bones.size(),
                " bones");
  Eigen::Matrix3Xd src(3, bones.size() - unnamed), dst(3, bones.size() - unnamed);
  for (std::size_t b = 0, k = 0; b < bones.size(); ++b) {
    if (bone_joint[b] < 0) continue;
    const Vec3 h = mat4_translation(inverse(ch.skeleton.inverse_bind[bone_joint[b]]));
    for (int c = 0; c < 3; ++c) src(c, k) = heads[3 * b + c].get<double>(), dst(c, k) = h[c];
    ++k;
  }
  GATCORE_CHECK(src.cols() >= 3, json_in, ": only ", src.cols(), " of Blender's bones are joints of ", glb);
  const Eigen::Matrix4d to_bind = Eigen::umeyama(src, dst, true);
  double head_err = 0;
  for (Eigen::Index k = 0; k < src.cols(); ++k)
    head_err = std::max(head_err, ((to_bind.topLeftCorner<3, 3>() * src.col(k) + to_bind.topRightCorner<3, 1>()) -
                                   dst.col(k)).norm());
  const std::int64_t m = static_cast<std::int64_t>(doc.at("positions").size() / 3);
  Eigen::Matrix3Xd raw(3, m), ours(3, n);
  for (std::int64_t i = 0; i < m; ++i)
    for (int c = 0; c < 3; ++c) raw(c, i) = doc.at("positions")[3 * i + c].get<double>();
  for (std::int64_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c) ours(c, v) = ch.mesh.positions[3 * v + c];
  const double ours_diag = (ours.rowwise().maxCoeff() - ours.rowwise().minCoeff()).norm();
  Eigen::Matrix4d fit = to_bind;
  auto apply = [&](const Eigen::Matrix4d& t) {
    return Eigen::Matrix3Xd((t.topLeftCorner<3, 3>() * raw).colwise() + t.topRightCorner<3, 1>());
  };
  // Heads that do not fit exactly (the importer rebuilt a rest pose that
  // differs from the bind matrices): refine the fit on the vertices
  // themselves, each Blender vertex to its nearest one of ours (iterative
  // closest points). The artist-weight check below says whether it matched.
  if (head_err > 1e-4 * ours_diag)
    for (int round = 0; round < 20; ++round) {
      const Eigen::Matrix3Xd at = apply(fit);
      Eigen::Matrix3Xd near(3, m);
      for (std::int64_t i = 0; i < m; ++i) {
        Eigen::Index best = 0;
        (ours.colwise() - at.col(i)).colwise().squaredNorm().minCoeff(&best);
        near.col(i) = ours.col(best);
      }
      fit = Eigen::umeyama(raw, near, true);
    }
  const Eigen::Matrix3Xd moved = apply(fit);
  std::vector<double> pos(moved.data(), moved.data() + 3 * m);
  GATCORE_CHECK(static_cast<std::int64_t>(doc.at("artist").size()) == m &&
                    static_cast<std::int64_t>(doc.at("auto").size()) == m,
                json_in, ": ", m, " positions but ", doc.at("artist").size(), " artist and ", doc.at("auto").size(),
                " automatic weight rows");

  // gatcore's (welded) vertices on a grid; each Blender vertex goes to the
  // nearest one (within 1e-4 of the diagonal).
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (std::int64_t v = 0; v < n; ++v)
    for (int c = 0; c < 3; ++c)
      lo[c] = std::min(lo[c], ch.mesh.positions[3 * v + c]), hi[c] = std::max(hi[c], ch.mesh.positions[3 * v + c]);
  const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double cellw = 1e-3 * diag, tol = 1e-4 * diag;
  auto key = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return (static_cast<std::uint64_t>(x) * 73856093ULL) ^ (static_cast<std::uint64_t>(y) * 19349663ULL) ^
           (static_cast<std::uint64_t>(z) * 83492791ULL);
  };
  std::unordered_map<std::uint64_t, std::vector<std::int64_t>> grid;
  auto cell = [&](double x, int c) { return static_cast<std::int64_t>(std::floor((x - lo[c]) / cellw)); };
  for (std::int64_t v = 0; v < n; ++v)
    grid[key(cell(ch.mesh.positions[3 * v], 0), cell(ch.mesh.positions[3 * v + 1], 1),
             cell(ch.mesh.positions[3 * v + 2], 2))]
        .push_back(v);
  std::vector<float> artist(static_cast<std::size_t>(n * nj), 0.0f), blender(artist.size(), 0.0f);
  std::vector<std::int32_t> hits(static_cast<std::size_t>(n), 0);
  std::vector<std::uint8_t> solved(static_cast<std::size_t>(n), 0);
  std::int64_t unmatched = 0;
  double worst = 0;
  for (std::int64_t i = 0; i < m; ++i) {
    const double p[3] = {pos[3 * i], pos[3 * i + 1], pos[3 * i + 2]};
    std::int64_t best = -1;
    double bd = tol;
    const std::int64_t cx = cell(p[0], 0), cy = cell(p[1], 1), cz = cell(p[2], 2);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
          if (it == grid.end()) continue;
          for (std::int64_t v : it->second) {
            double d2 = 0;
            for (int c = 0; c < 3; ++c) d2 += (ch.mesh.positions[3 * v + c] - p[c]) * (ch.mesh.positions[3 * v + c] - p[c]);
            if (std::sqrt(d2) <= bd) bd = std::sqrt(d2), best = v;
          }
        }
    if (best < 0) {
      ++unmatched;
      continue;
    }
    worst = std::max(worst, bd);
    ++hits[best];
    // Blender keeps a seam's copies apart: the welded vertex takes their mean.
    for (const char* which : {"artist", "auto"}) {
      const auto& row = doc.at(which)[static_cast<std::size_t>(i)];
      float* out = (which[1] == 'r' ? artist : blender).data() + best * nj;
      double sum = 0;
      for (std::size_t k = 0; k + 1 < row.size(); k += 2) sum += row[k + 1].get<double>();
      if (which[1] == 'u' && sum > 0) solved[best] = 1;
      for (std::size_t k = 0; k + 1 < row.size(); k += 2) {
        const std::int32_t j = bone_joint.at(row[k].get<std::size_t>());
        if (j >= 0 && sum > 0) out[j] += static_cast<float>(row[k + 1].get<double>() / sum);
      }
    }
  }
  std::int64_t missing = 0;
  for (std::int64_t v = 0; v < n; ++v) {
    missing += hits[v] == 0;
    if (hits[v] > 1)
      for (std::int32_t j = 0; j < nj; ++j) {
        artist[v * nj + j] /= static_cast<float>(hits[v]);
        blender[v * nj + j] /= static_cast<float>(hits[v]);
      }
  }
  // The same cut as gatcore's bone heat.
  limit_weights_dense(blender, nj, bp.max_influences, bp.min_weight);
  const std::vector<float> truth = ch.mesh.weights.dense(nj);
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> heat = bone_heat_weights(ch, bp).dense(nj);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double match_l1 = weight_metrics(artist, truth, nj).l1_mean;
  std::int64_t n_solved = 0;
  for (auto s : solved) n_solved += s;
  const Score g = score(heat, truth, nj, {}), b = score(blender, truth, nj, {});
  const Score gs = score(heat, truth, nj, solved), bs = score(blender, truth, nj, solved);
  std::printf("%s: %lld vertices, %d joints | gatcore L1 %.4f dom %.3f (%.1f s) | blender L1 %.4f dom %.3f (%.1f s) "
              "| blender-solved %lld: gatcore %.4f blender %.4f | match: unmatched %lld missing %lld unnamed %d, "
              "artist L1 %.2g, heads %.2g\n",
              glb.c_str(), static_cast<long long>(n), nj, g.l1, g.dominant, secs, b.l1, b.dominant,
              doc.value("seconds", 0.0), static_cast<long long>(n_solved), gs.l1, bs.l1,
              static_cast<long long>(unmatched), static_cast<long long>(missing), unnamed, match_l1, head_err / diag);
  for (const auto& [label, w] : {std::pair<const char*, const std::vector<float>*>{"gatcore", &heat},
                                 {"blender", &blender}}) {
    if (confusions <= 0) break;
    std::printf("  %s's largest confusions (artist's joint -> predicted: vertices):", label);
    int shown = 0;
    for (const auto& [t, p, c] : dominant_confusions(*w, truth, nj)) {
      if (shown++ == confusions) break;
      std::printf(" %s->%s %lld;", ch.skeleton.names[t].c_str(), ch.skeleton.names[p].c_str(),
                  static_cast<long long>(c));
    }
    std::printf("\n");
    const std::vector<BodyRegion> region = body_regions(ch.skeleton);
    std::printf("  %s's boundaries (crossed / vertices):", label);
    for (const auto& b : boundary_confusions(*w, truth, nj, region))
      std::printf(" %s %lld/%lld;", boundary_name(b.boundary), static_cast<long long>(b.crossed),
                  static_cast<long long>(b.vertices));
    std::printf("\n");
  }
  // The match is right when Blender's artist weights, read through it, are
  // gatcore's own; only then is a score written. Bones gatcore has no joint
  // for may remain: the leaf bones ("Head_end") and IK targets Blender's FBX
  // import keeps. Where the artist weighted one, the artist-weight check
  // fails; the weight Blender gives one counts against Blender.
  if (unmatched > 0 || missing > 0 || match_l1 > 1e-3) {
    std::fprintf(stderr, "bone_heat_peer: %s: Blender's vertices do not match gatcore's (see above)\n", glb.c_str());
    return 1;
  }
  if (!json_out.empty()) {
    const std::vector<BodyRegion> region = body_regions(ch.skeleton);
    auto boundaries = [&](const std::vector<float>& w) {
      nlohmann::json list = nlohmann::json::array();
      for (const auto& b : boundary_confusions(w, truth, nj, region))
        list.push_back({{"boundary", boundary_name(b.boundary)}, {"vertices", b.vertices}, {"crossed", b.crossed}});
      return list;
    };
    nlohmann::json o = {{"character", glb},          {"vertices", n},        {"joints", nj},
                        {"gatcore_l1", g.l1},        {"gatcore_dominant", g.dominant},
                        {"blender_l1", b.l1},        {"blender_dominant", b.dominant},
                        {"solved_vertices", n_solved}, {"gatcore_l1_solved", gs.l1},
                        {"blender_l1_solved", bs.l1}, {"unmatched", unmatched},
                        {"missing", missing},        {"artist_match_l1", match_l1},
                        {"gatcore_seconds", secs},   {"blender_seconds", doc.value("seconds", 0.0)}};
    o["gatcore_boundaries"] = boundaries(heat);
    o["blender_boundaries"] = boundaries(blender);
    write_text_atomic(json_out, o.dump(1) + "\n");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::vector<std::string> a(argv + 1, argv + argc);
    if (a.size() == 4 && a[0] == "--procedural") {
      ProceduralOptions po;
      if (a[1] != "humanoid" && a[1] != "creature") {
        std::fprintf(stderr, "bone_heat_peer: --procedural expects humanoid or creature, got '%s'\n", a[1].c_str());
        return 2;
      }
      po.kind = a[1] == "humanoid" ? ProceduralKind::humanoid : ProceduralKind::creature;
      po.seed = static_cast<std::uint32_t>(std::stoul(a[2]));
      save_gltf_character(procedural_character(po), a[3]);
      return 0;
    }
    // Bone heat's settings, for experiments: --heat C, --no-visibility, ...
    BoneHeatParams bp;
    int confusions = 0;  // --confusions N: each method's N largest dominant-bone confusions
    std::vector<std::string> rest;
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (a[i] == "--heat" && i + 1 < a.size()) bp.heat = std::stof(a[++i]);
      else if (a[i] == "--no-visibility") bp.visibility = false;
      else if (a[i] == "--nearest-visible") bp.nearest_only = false;
      else if (a[i] == "--no-facing") bp.facing_distance = false;
      else if (a[i] == "--no-weight-limit") bp.cut_below = 0.0f;
      else if (a[i] == "--branch-cos" && i + 1 < a.size()) bp.branch_cos = std::stof(a[++i]);
      else if (a[i] == "--confusions" && i + 1 < a.size()) confusions = std::stoi(a[++i]);
      else rest.push_back(a[i]);
    }
    if (rest.size() == 2) return run(rest[0], rest[1], "", bp, confusions);
    if (rest.size() == 4 && rest[2] == "--json") return run(rest[0], rest[1], rest[3], bp, confusions);
    std::fprintf(stderr,
                 "usage: bone_heat_peer CHARACTER.glb BLENDER.json [--json OUT.json] [--heat C] [--no-visibility] [--nearest-visible] [--no-facing] [--no-weight-limit] [--branch-cos C] [--confusions N]\n"
                 "       bone_heat_peer --procedural humanoid|creature SEED OUT.glb\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bone_heat_peer: %s\n", e.what());
    return 1;
  }
}
