#include "gatcore/character/viz/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "gatcore/error.hpp"

namespace gatcore::character {

namespace {

// 5x7 glyphs, one string of 7 rows x 5 columns ('#' = ink).
const std::map<char, const char*>& font() {
  static const std::map<char, const char*> f = {
      {'0', " ### #   ##  ### # ###  ##   # ### "}, {'1', "  #   ##    #    #    #    #   ### "},
      {'2', " ### #   #    #   #   #   #   #####"}, {'3', "#####   #   #     #     ##   # ### "},
      {'4', "   #   ##  # # #  # #####   #    # "}, {'5', "######    ####     #    ##   # ### "},
      {'6', "  ##  #   #    #### #   ##   # ### "}, {'7', "#####    #   #   #   #    #    #   "},
      {'8', " ### #   ##   # ### #   ##   # ### "}, {'9', " ### #   ##   # ####    #   #  ##  "},
      {'.', "                          ##   ##  "}, {'-', "               #####               "},
      {'+', "       #    #  #####  #    #       "}, {':', "      ##   ##        ##   ##       "},
      {'/', "    #    #   #   #   #   #    #    "}, {'(', "   #   #   #    #    #     #     # "},
      {')', " #     #     #    #    #   #   #   "}, {' ', "                                   "},
      {'a', "           ###     # #####   # ####"}, {'b', "#    #    # ## ##  ##   ##   ##### "},
      {'c', "           ### #    #    #   # ### "}, {'d', "    #    # ## ##  ###   ##   # ####"},
      {'e', "           ### #   #######     ### "}, {'f', "  ##  #  # #   ###   #    #    #   "},
      {'g', "           #####   # ####    # ### "}, {'h', "#    #    # ## ##  ##   ##   ##   #"},
      {'i', "  #        ##    #    #    #   ### "}, {'j', "   #        ##    #    # #  #  ##  "},
      {'k', "#    #    #  # # #  ##   # #  #  # "}, {'l', " ##    #    #    #    #    #   ### "},
      {'m', "          ## # # # ## # ##   ##   #"}, {'n', "          # ## ##  ##   ##   ##   #"},
      {'o', "           ### #   ##   ##   # ### "}, {'p', "          #### #   ##### #    #    "},
      {'q', "           ## ##  ## ####    #    #"}, {'r', "          # ## ##  ##    #    #    "},
      {'s', "           #####     ###     ##### "}, {'t', " #    #   ###   #    #    #  #  ## "},
      {'u', "          #   ##   ##   ##  ## ## #"}, {'v', "          #   ##   ##   # # #   #  "},
      {'w', "          #   ##   ## # ## # # # # "}, {'x', "          #   # # #   #   # # #   #"},
      {'y', "          #   ##   # ####    # ### "}, {'z', "          #####   #   #   #   #####"},
  };
  return f;
}

void put(Image& img, int x, int y, const std::array<std::uint8_t, 3>& c) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
  const std::size_t i = 3 * (static_cast<std::size_t>(y) * img.width + x);
  img.rgb[i] = c[0], img.rgb[i + 1] = c[1], img.rgb[i + 2] = c[2];
}

void segment(Image& img, float x0, float y0, float x1, float y1, const std::array<std::uint8_t, 3>& c, int thick = 1) {
  const int steps = static_cast<int>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0)))) + 1;
  for (int s = 0; s <= steps; ++s) {
    const float t = static_cast<float>(s) / static_cast<float>(steps);
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0))), y = static_cast<int>(std::lround(y0 + t * (y1 - y0)));
    for (int dx = 0; dx < thick; ++dx)
      for (int dy = 0; dy < thick; ++dy) put(img, x + dx - thick / 2, y + dy - thick / 2, c);
  }
}

// "1e-3", "0.5", "20": short labels for tick values.
std::string label(double v) {
  char b[32];
  const double a = std::abs(v);
  if (v == 0.0) return "0";
  if (a >= 1e4 || a < 1e-2) {
    const int e = static_cast<int>(std::floor(std::log10(a) + 1e-9));
    const double m = v / std::pow(10.0, e);
    if (std::abs(m - std::round(m)) < 1e-6) std::snprintf(b, sizeof b, "%.0fe%d", m, e);
    else std::snprintf(b, sizeof b, "%.1fe%d", m, e);
  } else {
    std::snprintf(b, sizeof b, "%g", std::round(v * 1e4) / 1e4);
  }
  return b;
}

// Ticks at 1, 2, 5 x 10^k covering [lo, hi] with about `want` of them.
std::vector<double> linear_ticks(double lo, double hi, int want) {
  const double raw = (hi - lo) / std::max(1, want);
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  double step = p;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) {
      step = m * p;
      break;
    }
  std::vector<double> t;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) t.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  return t;
}

}  // namespace

int text_width(const std::string& text, int scale) { return static_cast<int>(text.size()) * 6 * scale - scale; }

void draw_text(Image& img, int x, int y, const std::string& text, const std::array<std::uint8_t, 3>& colour, int scale) {
  for (std::size_t k = 0; k < text.size(); ++k) {
    const auto it = font().find(text[k]);
    const char* g = it != font().end() ? it->second : font().at(' ');
    for (int r = 0; r < 7; ++r)
      for (int c = 0; c < 5; ++c) {
        const std::size_t i = static_cast<std::size_t>(r * 5 + c);
        if (g[i] == '#')
          for (int sy = 0; sy < scale; ++sy)
            for (int sx = 0; sx < scale; ++sx)
              put(img, x + static_cast<int>(k) * 6 * scale + c * scale + sx, y + r * scale + sy, colour);
      }
  }
}

Image plot_series(const std::vector<PlotSeries>& series, const PlotOptions& opt) {
  GATCORE_CHECK(opt.width >= 160 && opt.height >= 120, "plot_series: image of ", opt.width, "x", opt.height,
                " is too small (at least 160x120)");
  Image img;
  img.width = opt.width, img.height = opt.height;
  img.rgb.assign(static_cast<std::size_t>(opt.width) * opt.height * 3, 255);
  const std::array<std::uint8_t, 3> ink = {40, 40, 40}, grid = {225, 225, 225};
  static const std::array<std::uint8_t, 3> colours[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {214, 39, 40}};

  bool positive = true, any = false;
  double xlo = std::numeric_limits<double>::max(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  for (const PlotSeries& s : series) {
    GATCORE_CHECK(s.x.size() == s.y.size(), "plot_series: series '", s.name, "' has ", s.x.size(), " x and ",
                  s.y.size(), " y values");
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) positive = positive && s.y[i] > 0.0f;
  }
  const bool logy = opt.log_y && positive;
  const auto Yv = [&](float v) { return logy ? std::log10(double(v)) : double(v); };
  for (const PlotSeries& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      any = true;
      xlo = std::min(xlo, double(s.x[i])), xhi = std::max(xhi, double(s.x[i]));
      ylo = std::min(ylo, Yv(s.y[i])), yhi = std::max(yhi, Yv(s.y[i]));
    }
  if (!any) xlo = 0, xhi = 1, ylo = 0, yhi = 1;
  if (!(xhi > xlo)) xlo -= 0.5, xhi += 0.5;
  {  // 4 % headroom so curves do not run along the frame
    const double pad = 0.04 * (yhi - ylo);
    ylo -= pad, yhi += pad;
  }
  if (!(yhi > ylo)) ylo -= logy ? 0.5 : 0.5 * std::max(1e-6, std::abs(ylo)), yhi += logy ? 0.5 : 0.5 * std::max(1e-6, std::abs(yhi));
  // Margins: y tick labels on the left, x labels below.
  const int L = 62, R = opt.width - 16, T = 14, B = opt.height - 40;
  const auto X = [&](double x) { return L + (x - xlo) / (xhi - xlo) * (R - L); };
  const auto Y = [&](double y) { return B - (y - ylo) / (yhi - ylo) * (B - T); };

  // y ticks (values in data units; positions through Y of log10 when logy).
  std::vector<double> yt;
  if (logy) {
    const bool fine = yhi - ylo < 2.0;
    for (int d = static_cast<int>(std::floor(ylo)); d <= static_cast<int>(std::ceil(yhi)); ++d)
      for (double m : fine ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
        const double v = m * std::pow(10.0, d);
        if (std::log10(v) >= ylo - 1e-9 && std::log10(v) <= yhi + 1e-9) yt.push_back(v);
      }
    if (yt.size() < 2) {  // under a factor of 2: plain ticks inside the range
      yt.clear();
      for (double v : linear_ticks(std::pow(10.0, ylo), std::pow(10.0, yhi), 4))
        if (v > 0) yt.push_back(v);
    }
  } else {
    yt = linear_ticks(ylo, yhi, 5);
  }
  for (double v : yt) {
    const double y = Y(logy ? std::log10(v) : v);
    if (y < T - 0.5 || y > B + 0.5) continue;
    segment(img, float(L), float(y), float(R), float(y), grid);
    segment(img, float(L - 4), float(y), float(L), float(y), ink);
    const std::string s = label(v);
    draw_text(img, L - 7 - text_width(s), static_cast<int>(y) - 3, s, ink);
  }
  bool integral_x = true;  // epochs: no fractional ticks
  for (const PlotSeries& s : series)
    for (float x : s.x) integral_x = integral_x && (!std::isfinite(x) || x == std::round(x));
  for (double v : linear_ticks(xlo, xhi, std::max(2, (R - L) / 70))) {
    if (integral_x && v != std::round(v)) continue;
    const double x = X(v);
    segment(img, float(x), float(B), float(x), float(B + 4), ink);
    const std::string s = label(v);
    draw_text(img, static_cast<int>(x) - text_width(s) / 2, B + 8, s, ink);
  }
  segment(img, float(L), float(B), float(R), float(B), ink);
  segment(img, float(L), float(T), float(L), float(B), ink);
  draw_text(img, (L + R) / 2 - text_width(opt.x_label) / 2, B + 22, opt.x_label, ink);
  draw_text(img, 4, T - 10 < 0 ? 0 : 2, opt.y_label + (logy ? " (log)" : ""), ink);

  for (std::size_t k = 0; k < series.size(); ++k) {
    const PlotSeries& s = series[k];
    const auto& c = colours[k % 4];
    bool have = false;
    double px = 0, py = 0;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]) || (logy && !(s.y[i] > 0))) {
        have = false;
        continue;
      }
      const double x = X(s.x[i]), y = Y(Yv(s.y[i]));
      if (have) segment(img, float(px), float(py), float(x), float(y), c, 2);
      else segment(img, float(x), float(y), float(x), float(y), c, 3);  // a lone point stays visible
      px = x, py = y, have = true;
    }
  }
  // Legend on a white box, in the corner of the plot where it hides the
  // fewest curve pixels (top right unless a curve ends there: a validation
  // curve that ends high stays visible).
  int wmax = 0;
  for (const PlotSeries& o : series) wmax = std::max(wmax, text_width(o.name));
  const int box_w = wmax + 30, box_h = 12 * static_cast<int>(series.size()) + 4;
  const int corners[4][2] = {{R - 4 - box_w, T + 3}, {L + 4, T + 3}, {R - 4 - box_w, B - 3 - box_h}, {L + 4, B - 3 - box_h}};
  int best = 0;
  long best_hidden = -1;
  for (int k = 0; k < 4; ++k) {
    long hidden = 0;
    for (int yy = corners[k][1]; yy < corners[k][1] + box_h; ++yy)
      for (int xx = corners[k][0]; xx < corners[k][0] + box_w; ++xx) {
        if (xx < 0 || yy < 0 || xx >= img.width || yy >= img.height) continue;
        for (std::size_t c = 0; c < series.size(); ++c) hidden += img.at(xx, yy) == colours[c % 4];
      }
    if (best_hidden < 0 || hidden < best_hidden) best = k, best_hidden = hidden;
  }
  const int bx = corners[best][0], by = corners[best][1];
  for (int yy = by; yy < by + box_h; ++yy)
    for (int xx = bx; xx < bx + box_w; ++xx) put(img, xx, yy, {255, 255, 255});
  for (std::size_t k = 0; k < series.size(); ++k) {
    const int lx = bx + 4, ly = by + 3 + 12 * static_cast<int>(k);
    segment(img, float(lx), float(ly + 3), float(lx + 16), float(ly + 3), colours[k % 4], 2);
    draw_text(img, lx + 20, ly, series[k].name, ink);
  }
  return img;
}

}  // namespace gatcore::character
