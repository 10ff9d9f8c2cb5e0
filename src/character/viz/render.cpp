#include "gatcore/character/viz/render.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#include "gatcore/atomic_file.hpp"
#include <zlib.h>

#include "gatcore/character/viz/plot.hpp"
#include "gatcore/error.hpp"

namespace gatcore::character {

std::array<std::uint8_t, 3> error_colour(float t) {
  if (!(t >= 0.0f)) t = 0.0f;
  t = std::min(t, 1.0f);
  // Piecewise linear through blue, cyan, green, yellow, red.
  static const float stops[5][3] = {{0.1f, 0.2f, 0.9f}, {0.1f, 0.8f, 0.9f}, {0.2f, 0.8f, 0.2f}, {0.95f, 0.85f, 0.1f},
                                    {0.9f, 0.1f, 0.1f}};
  const float x = t * 4.0f;
  const int i = std::min(3, static_cast<int>(x));
  const float u = x - i;
  std::array<std::uint8_t, 3> c;
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<std::uint8_t>(std::lround(255.0f * (stops[i][k] + u * (stops[i + 1][k] - stops[i][k]))));
  return c;
}

namespace {

void put(Image& img, int x, int y, const std::array<std::uint8_t, 3>& c) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
  const std::size_t i = 3 * (static_cast<std::size_t>(y) * img.width + x);
  img.rgb[i] = c[0];
  img.rgb[i + 1] = c[1];
  img.rgb[i + 2] = c[2];
}

Image blank(int w, int h) {
  GATCORE_CHECK(w > 0 && h > 0 && w <= 16384 && h <= 16384, "image size must be in [1, 16384], got ", w, "x", h);
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.assign(static_cast<std::size_t>(w) * h * 3, 255);
  return img;
}

void line(Image& img, float x0, float y0, float x1, float y1, const std::array<std::uint8_t, 3>& c) {
  const int steps = static_cast<int>(std::max(std::abs(x1 - x0), std::abs(y1 - y0))) + 1;
  for (int s = 0; s <= steps; ++s) {
    const float t = static_cast<float>(s) / steps;
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0))), y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
    put(img, x, y, c);
    put(img, x, y + 1, c);
  }
}

}  // namespace

Image render_error_map(std::span<const float> positions, std::span<const std::int32_t> triangles,
                       std::span<const float> error, const RenderOptions& opt) {
  GATCORE_CHECK(positions.size() % 3 == 0 && triangles.size() % 3 == 0 && error.size() == positions.size() / 3,
                "render_error_map: ", positions.size() / 3, " vertices, ", error.size(), " errors");
  Image img = blank(opt.width, opt.height);
  const std::int64_t n = static_cast<std::int64_t>(error.size());
  if (n == 0) return img;
  auto norm = [](Vec3 v) {
    const float l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    GATCORE_CHECK(l > 0.0f, "render_error_map: zero view or up vector");
    return Vec3{v[0] / l, v[1] / l, v[2] / l};
  };
  const Vec3 f = norm(opt.view_dir);
  const Vec3 r = norm({f[1] * opt.up[2] - f[2] * opt.up[1], f[2] * opt.up[0] - f[0] * opt.up[2],
                       f[0] * opt.up[1] - f[1] * opt.up[0]});
  const Vec3 u = {r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]};
  std::vector<float> sx(n), sy(n), sz(n);
  float lo[2] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max()}, hi[2] = {-lo[0], -lo[1]};
  float emax = opt.max_error;
  for (std::int64_t v = 0; v < n; ++v) {
    const float* p = &positions[3 * v];
    sx[v] = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
    sy[v] = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    sz[v] = p[0] * f[0] + p[1] * f[1] + p[2] * f[2];
    lo[0] = std::min(lo[0], sx[v]);
    hi[0] = std::max(hi[0], sx[v]);
    lo[1] = std::min(lo[1], sy[v]);
    hi[1] = std::max(hi[1], sy[v]);
    if (opt.max_error <= 0.0f && std::isfinite(error[v])) emax = std::max(emax, error[v]);
  }
  if (!(emax > 0.0f)) emax = 1.0f;
  const int bar = opt.colour_bar ? std::max(8, opt.width / 24) : 0;
  // The bar's numbers (0, half, the top of the scale) left of it.
  const auto number = [](float v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", static_cast<double>(v));
    return std::string(b);
  };
  const std::string top_label = number(emax) + (opt.max_error > 0.0f ? "+" : "");
  const int label_w = bar ? std::max(text_width(top_label), text_width(number(0.5f * emax))) + 4 : 0;
  const int right = bar + label_w;  // reserved on the right
  const float margin = 0.05f;
  const float avail_w = (opt.width - 2 * right) * (1 - 2 * margin), avail_h = opt.height * (1 - 2 * margin);
  const float ext = std::max((hi[0] - lo[0]) / avail_w, (hi[1] - lo[1]) / avail_h);
  const float scale = ext > 0.0f ? 1.0f / ext : 1.0f;
  const float cx = 0.5f * (lo[0] + hi[0]), cy = 0.5f * (lo[1] + hi[1]);
  for (std::int64_t v = 0; v < n; ++v) {
    sx[v] = 0.5f * (opt.width - right) + (sx[v] - cx) * scale;
    sy[v] = 0.5f * opt.height - (sy[v] - cy) * scale;
  }
  std::vector<float> zbuf(static_cast<std::size_t>(opt.width) * opt.height, std::numeric_limits<float>::infinity());
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const std::int32_t a = triangles[t], b = triangles[t + 1], c = triangles[t + 2];
    GATCORE_CHECK(a >= 0 && b >= 0 && c >= 0 && a < n && b < n && c < n, "render_error_map: triangle ", t / 3,
                  " references a missing vertex");
    const float area = (sx[b] - sx[a]) * (sy[c] - sy[a]) - (sx[c] - sx[a]) * (sy[b] - sy[a]);
    if (std::abs(area) < 1e-12f) continue;
    // Facing: |cos| between the 3-D normal and the view direction.
    const float* pa = &positions[3 * a];
    const float* pb = &positions[3 * b];
    const float* pc = &positions[3 * c];
    const float e1[3] = {pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]}, e2[3] = {pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]};
    const float nn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const float nl = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
    const float shade = 0.35f + 0.65f * (nl > 0.0f ? std::abs(nn[0] * f[0] + nn[1] * f[1] + nn[2] * f[2]) / nl : 1.0f);
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({sx[a], sx[b], sx[c]}))));
    const int x1 = std::min(opt.width - 1, static_cast<int>(std::ceil(std::max({sx[a], sx[b], sx[c]}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({sy[a], sy[b], sy[c]}))));
    const int y1 = std::min(opt.height - 1, static_cast<int>(std::ceil(std::max({sy[a], sy[b], sy[c]}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const float px = x + 0.5f, py = y + 0.5f;
        const float w0 = ((sx[b] - px) * (sy[c] - py) - (sx[c] - px) * (sy[b] - py)) / area;
        const float w1 = ((sx[c] - px) * (sy[a] - py) - (sx[a] - px) * (sy[c] - py)) / area;
        const float w2 = 1.0f - w0 - w1;
        if (w0 < 0.0f || w1 < 0.0f || w2 < 0.0f) continue;
        const float z = w0 * sz[a] + w1 * sz[b] + w2 * sz[c];
        float& zb = zbuf[static_cast<std::size_t>(y) * opt.width + x];
        if (z >= zb) continue;
        zb = z;
        const float e = (w0 * error[a] + w1 * error[b] + w2 * error[c]) / emax;
        auto col = error_colour(e);
        for (auto& ch : col) ch = static_cast<std::uint8_t>(std::lround(ch * shade));
        put(img, x, y, col);
      }
  }
  if (bar) {
    const int y0 = opt.height / 10, y1 = opt.height * 9 / 10;
    for (int y = y0; y < y1; ++y) {
      const float t = 1.0f - static_cast<float>(y - y0) / static_cast<float>(y1 - y0);
      for (int x = opt.width - bar; x < opt.width - bar / 3; ++x) put(img, x, y, error_colour(t));
    }
    // Errors above a fixed scale top are clamped to red: "+" says so.
    const std::array<std::uint8_t, 3> ink{40, 40, 40};
    const std::string labels[3] = {top_label, number(0.5f * emax), "0"};
    const int ys[3] = {y0, (y0 + y1) / 2, y1 - 1};
    for (int k = 0; k < 3; ++k)
      draw_text(img, opt.width - bar - 3 - text_width(labels[k]), std::clamp(ys[k] - 3, 0, opt.height - 7), labels[k],
                ink);
  }
  return img;
}

Image plot_curves(const std::vector<std::vector<float>>& series, int width, int height, bool log_y) {
  Image img = blank(width, height);
  float lo = std::numeric_limits<float>::max(), hi = -lo;
  std::size_t len = 0;
  bool positive = true;
  for (const auto& s : series)
    for (float v : s) {
      GATCORE_CHECK(std::isfinite(v), "plot_curves: a value is not finite");
      positive = positive && v > 0.0f;
    }
  const bool logy = log_y && positive;
  for (const auto& s : series) {
    len = std::max(len, s.size());
    for (float v : s) {
      const float y = logy ? std::log10(v) : v;
      lo = std::min(lo, y);
      hi = std::max(hi, y);
    }
  }
  const float L = 0.08f * width, R = 0.97f * width, T = 0.05f * height, B = 0.9f * height;
  const std::array<std::uint8_t, 3> axis = {60, 60, 60}, grid = {225, 225, 225};
  if (len == 0) return img;
  if (!(hi > lo)) {
    hi = lo + 1.0f;
    lo -= 1.0f;
  }
  if (logy)
    for (int d = static_cast<int>(std::floor(lo)); d <= static_cast<int>(std::ceil(hi)); ++d) {
      const float y = B - (d - lo) / (hi - lo) * (B - T);
      if (y >= T && y <= B) line(img, L, y, R, y, grid);
    }
  line(img, L, B, R, B, axis);
  line(img, L, T, L, B, axis);
  static const std::array<std::uint8_t, 3> colours[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {214, 39, 40}};
  for (std::size_t k = 0; k < series.size(); ++k) {
    const auto& s = series[k];
    for (std::size_t i = 0; i + 1 < s.size(); ++i) {
      auto X = [&](std::size_t j) { return L + (len > 1 ? static_cast<float>(j) / (len - 1) : 0.0f) * (R - L); };
      auto Y = [&](float v) { return B - ((logy ? std::log10(v) : v) - lo) / (hi - lo) * (B - T); };
      line(img, X(i), Y(s[i]), X(i + 1), Y(s[i + 1]), colours[k % 4]);
    }
  }
  return img;
}

namespace {

std::uint32_t crc32(const std::uint8_t* p, std::size_t n, std::uint32_t c = 0xFFFFFFFFu) {
  static std::uint32_t table[256];
  static bool init = [] {
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t x = i;
      for (int k = 0; k < 8; ++k) x = (x & 1) ? 0xEDB88320u ^ (x >> 1) : x >> 1;
      table[i] = x;
    }
    return true;
  }();
  (void)init;
  for (std::size_t i = 0; i < n; ++i) c = table[(c ^ p[i]) & 0xFF] ^ (c >> 8);
  return c;
}

void be32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(v >> s));
}

void chunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
  be32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  be32(out, crc32(out.data() + start, out.size() - start) ^ 0xFFFFFFFFu);
}

}  // namespace

void write_png(const std::string& path, const Image& img) {
  GATCORE_CHECK(img.width > 0 && img.height > 0 &&
                    img.rgb.size() == static_cast<std::size_t>(img.width) * img.height * 3,
                path, ": image of ", img.width, "x", img.height, " with ", img.rgb.size(), " bytes");
  // Each row gets the PNG filter whose output has the smallest sum of
  // absolute (signed) bytes, libpng's heuristic, then zlib at level 9: a
  // loss curve or an error map is mostly flat colour and shrinks 20-200x
  // (bench/RESULTS.md has the figures).
  const std::size_t stride = 3 * static_cast<std::size_t>(img.width);
  std::vector<std::uint8_t> raw(static_cast<std::size_t>(img.height) * (stride + 1));
  std::vector<std::uint8_t> zero(stride, 0), cand(stride);
  for (int y = 0; y < img.height; ++y) {
    const std::uint8_t* cur = img.rgb.data() + static_cast<std::size_t>(y) * stride;
    const std::uint8_t* up = y > 0 ? cur - stride : zero.data();
    std::uint8_t* out = raw.data() + static_cast<std::size_t>(y) * (stride + 1);
    std::uint64_t best = ~std::uint64_t{0};
    for (std::uint8_t filter = 0; filter < 5; ++filter) {
      std::uint64_t cost = 0;
      for (std::size_t i = 0; i < stride; ++i) {
        const int a = i >= 3 ? cur[i - 3] : 0, b = up[i], c = i >= 3 ? up[i - 3] : 0;
        int pred = 0;
        if (filter == 1) pred = a;
        if (filter == 2) pred = b;
        if (filter == 3) pred = (a + b) / 2;
        if (filter == 4) {
          const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
          pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
        }
        cand[i] = static_cast<std::uint8_t>(cur[i] - pred);
        cost += static_cast<std::uint64_t>(std::abs(static_cast<int>(static_cast<std::int8_t>(cand[i]))));
      }
      if (cost < best) {
        best = cost;
        out[0] = filter;
        std::copy(cand.begin(), cand.end(), out + 1);
      }
    }
  }
  uLongf zlen = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> z(zlen);
  const int zrc = compress2(z.data(), &zlen, raw.data(), static_cast<uLong>(raw.size()), Z_BEST_COMPRESSION);
  GATCORE_CHECK(zrc == Z_OK, path, ": zlib could not compress the image (", zError(zrc), ")");
  z.resize(zlen);
  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> ihdr;
  be32(ihdr, static_cast<std::uint32_t>(img.width));
  be32(ihdr, static_cast<std::uint32_t>(img.height));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8-bit RGB, deflate, no filter, no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", z);
  chunk(png, "IEND", {});
  // Atomic: a picture that is rewritten while training (the loss curve) is
  // never seen half written.
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

}  // namespace gatcore::character
