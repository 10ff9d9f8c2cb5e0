#include "src/character/rig/weld.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include "gatcore/error.hpp"

namespace gatcore::character {

void weld_into(Character& ch, const std::vector<float>& pos, const std::vector<std::vector<std::pair<int, float>>>& infl,
               const std::vector<std::int32_t>& tris, float tolerance) {
  const std::int64_t nfile = static_cast<std::int64_t>(pos.size() / 3);
  GATCORE_CHECK(std::isfinite(tolerance) && tolerance >= 0.0f, ch.name, ": the weld tolerance must be a finite ",
                "fraction >= 0 of the diagonal, got ", tolerance);
  if (nfile == 0) return;
  for (std::int64_t i = 0; i < 3 * nfile; ++i)
    GATCORE_CHECK(std::isfinite(pos[i]), ch.name, ": vertex ", i / 3, " is not finite (", pos[i], ")");
  // Weld by position (hash grid with cells of the tolerance). In double: a
  // file's finite floats can span more than FLT_MAX (3e38 and -3e38), whose
  // float difference is infinite and made the cells NaN.
  double lo[3], hi[3];
  for (int c = 0; c < 3; ++c) lo[c] = hi[c] = pos[c];
  for (std::int64_t v = 0; v < nfile; ++v)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], double(pos[3 * v + c]));
      hi[c] = std::max(hi[c], double(pos[3 * v + c]));
    }
  const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  const double tol = std::max(static_cast<double>(tolerance) * diag, 1e-30);
  // Cells past +-2^52 (a tolerance of 0 over a metre-sized mesh, a vertex
  // far from the rest) share the edge cell: the distance test below still
  // decides every weld, so a shared cell costs comparisons, not correctness.
  auto cell = [&](std::int64_t v, int c) {
    const double x = std::floor((double(pos[3 * v + c]) - lo[c]) / tol);
    return static_cast<std::int64_t>(std::min(x, 0x1p52));
  };
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::uint64_t>(x) * 73856093ULL ^ static_cast<std::uint64_t>(y) * 19349663ULL ^
           static_cast<std::uint64_t>(z) * 83492791ULL;
  };
  std::unordered_multimap<std::uint64_t, std::int32_t> grid;
  grid.reserve(static_cast<std::size_t>(nfile));
  ch.welded_from_file.assign(static_cast<std::size_t>(nfile), -1);
  std::vector<std::int64_t> first_file;  // welded -> first file vertex
  for (std::int64_t v = 0; v < nfile; ++v) {
    const std::int64_t cx = cell(v, 0), cy = cell(v, 1), cz = cell(v, 2);
    std::int32_t found = -1;
    for (int dx = -1; dx <= 1 && found < 0; ++dx)
      for (int dy = -1; dy <= 1 && found < 0; ++dy)
        for (int dz = -1; dz <= 1 && found < 0; ++dz) {
          auto range = grid.equal_range(key(cx + dx, cy + dy, cz + dz));
          for (auto it = range.first; it != range.second; ++it) {
            const std::int64_t u = first_file[it->second];
            double d2 = 0.0;
            for (int c = 0; c < 3; ++c) {
              const double e = double(pos[3 * u + c]) - double(pos[3 * v + c]);
              d2 += e * e;
            }
            if (d2 <= tol * tol) {
              found = it->second;
              break;
            }
          }
        }
    if (found < 0) {
      found = static_cast<std::int32_t>(first_file.size());
      first_file.push_back(v);
      grid.emplace(key(cx, cy, cz), found);
    }
    ch.welded_from_file[v] = found;
  }
  const std::int64_t nw = static_cast<std::int64_t>(first_file.size());
  Mesh& mesh = ch.mesh;
  mesh.positions.resize(3 * nw);
  for (std::int64_t w = 0; w < nw; ++w)
    for (int c = 0; c < 3; ++c) mesh.positions[3 * w + c] = pos[3 * first_file[w] + c];
  // Weights: the average of the merged file vertices' normalised weights.
  std::vector<std::map<int, double>> acc(static_cast<std::size_t>(nw));
  for (std::int64_t v = 0; v < nfile; ++v) {
    double sum = 0.0;
    for (const auto& [j, w] : infl[v]) sum += w;
    for (const auto& [j, w] : infl[v]) acc[ch.welded_from_file[v]][j] += w / sum;
  }
  mesh.weights.ptr.assign(1, 0);
  for (std::int64_t w = 0; w < nw; ++w) {
    double sum = 0.0;
    for (const auto& [j, x] : acc[w]) sum += x;
    for (const auto& [j, x] : acc[w]) {
      mesh.weights.joint.push_back(j);
      mesh.weights.weight.push_back(static_cast<float>(x / sum));
    }
    mesh.weights.ptr.push_back(static_cast<std::int64_t>(mesh.weights.joint.size()));
  }
  for (std::size_t t = 0; t + 2 < tris.size(); t += 3) {
    const std::int32_t a = ch.welded_from_file[tris[t]], b = ch.welded_from_file[tris[t + 1]],
                       c = ch.welded_from_file[tris[t + 2]];
    if (a == b || b == c || a == c) continue;  // collapsed by the weld
    mesh.triangles.insert(mesh.triangles.end(), {a, b, c});
  }
}

}  // namespace gatcore::character
