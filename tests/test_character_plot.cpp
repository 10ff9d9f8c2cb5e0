// Loss curves: plot_series with axes, ticks and legend, the history files
// gat train writes, and the PNG decoded by libpng (an independent decoder).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include "gatcore/character/viz/loss_curve.hpp"
#include "gatcore/character/viz/plot.hpp"
#include "gatcore/error.hpp"
#include "png_read.hpp"

using namespace gatcore::character;
using Catch::Matchers::Contains;

namespace {

std::string tmp(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "gatcore_plot_tests";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

Image decode_png(const std::string& path) { return gatcore::test::read_png(path); }

int count_colour(const Image& img, std::array<std::uint8_t, 3> c, int x0 = 0, int x1 = -1) {
  int n = 0;
  if (x1 < 0) x1 = img.width;
  for (int y = 0; y < img.height; ++y)
    for (int x = x0; x < x1; ++x) n += img.at(x, y) == c;
  return n;
}

}  // namespace

TEST_CASE("text drawing: glyphs differ and have ink", "[character][plot]") {
  std::set<std::string> seen;
  for (char c : std::string("0123456789.-+:/()abcdefghijklmnopqrstuvwxyz")) {
    Image img;
    img.width = 6, img.height = 7;
    img.rgb.assign(6 * 7 * 3, 255);
    draw_text(img, 0, 0, std::string(1, c), {0, 0, 0});
    CHECK(count_colour(img, {0, 0, 0}) > 0);
    CHECK(seen.insert(std::string(img.rgb.begin(), img.rgb.end())).second);  // no two characters share a glyph
  }
  CHECK(text_width("abc") == 17);
  CHECK(text_width("abc", 2) == 34);
}

TEST_CASE("the loss curve and history files gat train writes", "[character][plot][loss]") {
  std::vector<LossRecord> h;
  for (int e = 1; e <= 30; ++e) h.push_back({e, 2.0 * std::exp(-0.2 * e), 3.0 * std::exp(-0.15 * e), 1e-3, 0.5});
  const std::string png = tmp("curve.png");
  std::filesystem::remove(history_csv_path(png));
  write_loss_outputs(h, png);
  CHECK(!std::filesystem::exists(png + ".tmp"));
  const Image img = decode_png(png);
  CHECK(img.width == 720);
  CHECK(img.height == 440);
  // Both series are drawn (their colours), the axes and labels are ink.
  const int blue = count_colour(img, {31, 119, 180}), orange = count_colour(img, {255, 127, 14});
  CHECK(blue > 400);
  CHECK(orange > 400);
  CHECK(count_colour(img, {40, 40, 40}, 0, 60) > 150);  // y tick labels left of the axis
  CHECK(count_colour(img, {255, 255, 255}) > img.width * img.height / 2);
  // Log scale: the train curve (an exponential) is a straight line, so its
  // pixels in the middle column sit halfway between those at both ends.
  const auto mean_row = [&](int x) {
    double s = 0;
    int n = 0;
    for (int y = 0; y < img.height; ++y)
      if (img.at(x, y) == std::array<std::uint8_t, 3>{31, 119, 180}) s += y, ++n;
    REQUIRE(n > 0);
    return s / n;
  };
  const int L = 62, R = 720 - 16;
  const double a = mean_row(L + 20), m = mean_row((L + R) / 2), b = mean_row(R - 60);
  const double mid_x = ((L + R) / 2 - (L + 20)) / double((R - 60) - (L + 20));
  CHECK(m == Approx(a + mid_x * (b - a)).margin(3.0));

  std::ifstream f(history_csv_path(png));
  std::string line;
  std::getline(f, line);
  CHECK(line == "epoch,train_loss,val_loss,lr,seconds,val_l1,val_dominant");
  int rows = 0;
  while (std::getline(f, line)) ++rows;
  CHECK(rows == 30);
  CHECK(history_csv_path("a/b.png") == "a/b.csv");
  CHECK(default_curve_path("runs/m.gcm") == "runs/m.loss.png");
  CHECK(default_curve_path("runs.v2/model") == "runs.v2/model.loss.png");

  // The metadata round trip (resume continues the curve), and bad strings.
  const std::vector<LossRecord> back = parse_history(format_history(h), "m.gcm");
  REQUIRE(back.size() == h.size());
  CHECK(back[4].epoch == 5);
  CHECK(back[4].train == Approx(h[4].train).epsilon(1e-8));
  CHECK(back[4].val == Approx(h[4].val).epsilon(1e-8));
  CHECK(back[4].val_l1 < 0);  // not measured: five fields, as older checkpoints hold
  CHECK_THROWS_WITH(parse_history("1:0.5:x", "m.gcm"), Contains("m.gcm") && Contains("'1:0.5:x'"));
  // Skin-weight runs add the validation L1 as a sixth field; both forms read.
  // and the dominant-bone accuracy as a seventh.
  std::vector<LossRecord> w = {
      {1, 0.9, 0.8, 1e-3, 2.0, 0.45, -1}, {2, 0.7, 0.75, 1e-3, 2.0, -1, -1}, {3, 0.6, 0.7, 1e-3, 2.0, 0.4, 0.875}};
  const std::vector<LossRecord> wb = parse_history(format_history(w), "w.gcm");
  REQUIRE(wb.size() == 3);
  CHECK(wb[0].val_l1 == Approx(0.45).epsilon(1e-8));
  CHECK(wb[0].val_dominant < 0);
  CHECK(wb[1].val_l1 < 0);
  CHECK(wb[2].val_l1 == Approx(0.4).epsilon(1e-8));
  CHECK(wb[2].val_dominant == Approx(0.875).epsilon(1e-8));
  write_loss_outputs(w, tmp("w.png"));
  std::ifstream wf(history_csv_path(tmp("w.png")));
  std::vector<std::string> wl;
  for (std::string x; std::getline(wf, x);) wl.push_back(x);
  REQUIRE(wl.size() == 4);
  CHECK(wl[1] == "1,0.9,0.8,0.001,2,0.45,");
  CHECK(wl[2] == "2,0.7,0.75,0.001,2,,");
  CHECK(wl[3] == "3,0.6,0.7,0.001,2,0.4,0.875");
  CHECK(parse_history("3:0.5:0.4:0.001:1.5", "old.gcm")[0].val_l1 < 0);
  CHECK_THROWS_WITH(parse_history("3:0.5:0.4:0.001:1.5:", "m.gcm"), Contains("malformed"));
  CHECK_THROWS_WITH(parse_history("3:0.5:0.4:0.001:1.5:0.2:7", "m.gcm"), Contains("malformed"));  // a fraction
  CHECK_THROWS_WITH(parse_history("3:0.5:0.4:0.001:1.5:0.2:0.7:1", "m.gcm"), Contains("malformed"));
  CHECK_THROWS_WITH(parse_history("3:0.5:0.4:0.001:1.5x", "m.gcm"), Contains("malformed"));
  CHECK_THROWS_WITH(write_loss_outputs(h, tmp("no_dir/c.png")), Contains("c.csv"));
}

TEST_CASE("plot_series: one point, no validation, non-positive values, bad sizes", "[character][plot]") {
  const Image one = plot_series({{"train", {1.f}, {0.5f}}});
  CHECK(count_colour(one, {31, 119, 180}) > 0);
  const Image lin = plot_series({{"train", {1.f, 2.f, 3.f}, {0.f, -1.f, 2.f}}});  // falls back to a linear axis
  CHECK(count_colour(lin, {31, 119, 180}) > 50);
  CHECK_THROWS_WITH(plot_series({{"train", {1.f, 2.f}, {1.f}}}), Contains("'train' has 2 x and 1 y"));
  PlotOptions tiny;
  tiny.width = 10;
  CHECK_THROWS_WITH(plot_series({}, tiny), Contains("too small"));
}
