#pragma once
// Pictures without a GPU: a small z-buffered software rasteriser for
// per-vertex error colour maps of a posed character (like the papers' error
// figures), a line plot for loss curves, and a PNG writer (zlib).
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "gatcore/character/rig/transform.hpp"

namespace gatcore::character {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  // [height][width][3], top row first
  std::array<std::uint8_t, 3> at(int x, int y) const {
    const std::size_t i = 3 * (static_cast<std::size_t>(y) * width + x);
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// t in [0, 1] -> blue (0) .. cyan .. green .. yellow .. red (1); clamped.
std::array<std::uint8_t, 3> error_colour(float t);

struct RenderOptions {
  int width = 512, height = 512;
  Vec3 view_dir{0.0f, 0.0f, -1.0f};  // the camera looks along this (default: at a character facing +Z)
  Vec3 up{0.0f, 1.0f, 0.0f};
  float max_error = 0.0f;  // colour scale top; <= 0: the largest error
  bool colour_bar = true;  // a vertical scale on the right edge
};

// Orthographic view fitted to the mesh, Gouraud-interpolated error colours,
// shaded by the facing of each triangle; white background.
Image render_error_map(std::span<const float> positions, std::span<const std::int32_t> triangles,
                       std::span<const float> error, const RenderOptions& opt = {});

// Line plot of one or more series (e.g. train / validation loss per epoch),
// y on a log scale when `log_y` and all values are positive.
Image plot_curves(const std::vector<std::vector<float>>& series, int width = 640, int height = 400, bool log_y = true);

// 8-bit RGB PNG, filtered per row and zlib-compressed. Throws
// InvalidArgument naming the path if it cannot be written.
void write_png(const std::string& path, const Image& img);

}  // namespace gatcore::character
