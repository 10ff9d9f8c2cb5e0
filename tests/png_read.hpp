#pragma once
// Reads a PNG with libpng (an independent decoder: the round trip of
// write_png is checked by the library everyone else reads PNGs with).
#include <catch2/catch.hpp>

#include <png.h>

#include <cstring>
#include <string>

#include "gatcore/character/viz/render.hpp"

namespace gatcore::test {

inline character::Image read_png(const std::string& path) {
  png_image image;
  std::memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  REQUIRE(png_image_begin_read_from_file(&image, path.c_str()));
  // The writer's format: 8-bit RGB, no alpha, no palette.
  CHECK(image.format == PNG_FORMAT_RGB);
  image.format = PNG_FORMAT_RGB;
  character::Image img;
  img.width = int(image.width);
  img.height = int(image.height);
  img.rgb.resize(PNG_IMAGE_SIZE(image));
  REQUIRE(png_image_finish_read(&image, nullptr, img.rgb.data(), 0, nullptr));
  return img;
}

}  // namespace gatcore::test
