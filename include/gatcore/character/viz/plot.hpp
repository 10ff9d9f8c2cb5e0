#pragma once
// Line plots with axes, tick labels and a legend (training loss curves),
// drawn with the software rasteriser's Image and a built-in 5x7 pixel font.
#include <string>
#include <vector>

#include "gatcore/character/viz/render.hpp"

namespace gatcore::character {

struct PlotSeries {
  std::string name;      // legend entry
  std::vector<float> x;  // e.g. epochs
  std::vector<float> y;  // same length as x; non-finite points are skipped
};

struct PlotOptions {
  int width = 720, height = 440;
  bool log_y = true;  // log10 y axis when every plotted value is positive
  std::string x_label = "epoch", y_label = "loss";
};

// White background, grey grid at the y ticks (decades on a log axis, with
// 2 and 5 when the range is under two decades), tick labels on both axes,
// each series in its own colour, a legend in the top right corner.
Image plot_series(const std::vector<PlotSeries>& series, const PlotOptions& opt = {});

// Draws `text` (digits, lower-case letters, space and . - + : / ( )) with its
// top-left corner at (x, y), `scale` pixels per font pixel.
void draw_text(Image& img, int x, int y, const std::string& text, const std::array<std::uint8_t, 3>& colour,
               int scale = 1);
// Width in pixels of `text` drawn at `scale`.
int text_width(const std::string& text, int scale = 1);

}  // namespace gatcore::character
