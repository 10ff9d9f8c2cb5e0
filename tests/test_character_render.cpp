// Error colour maps, loss curves, PNG writing.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "character_fixtures.hpp"
#include "gatcore/character/deform/deform.hpp"
#include "gatcore/character/viz/render.hpp"
#include "gatcore/error.hpp"
#include "png_read.hpp"

using namespace gatcore::character;

namespace {

using gatcore::test::read_png;

}  // namespace

TEST_CASE("error colour scale", "[character][render]") {
  const auto lo = error_colour(0.0f), hi = error_colour(1.0f), mid = error_colour(0.5f);
  CHECK(lo[2] > lo[0]);   // blue
  CHECK(hi[0] > hi[2]);   // red
  CHECK(mid[1] > mid[0]); // green
  CHECK(error_colour(-1.0f) == lo);
  CHECK(error_colour(7.0f) == hi);
}

TEST_CASE("error map: colours follow the error, the nearer surface wins", "[character][render]") {
  // A unit square facing the camera (+Z), error 0 on the left, 1 on the right;
  // behind it (z = -1), a larger square with error 1 everywhere.
  const std::vector<float> p = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, -1, -1, 2, -1, -1, 2, 2, -1, -1, 2, -1};
  const std::vector<std::int32_t> t = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7};
  const std::vector<float> e = {0, 1, 1, 0, 1, 1, 1, 1};
  RenderOptions o;
  o.width = 200;
  o.height = 200;
  o.colour_bar = false;
  const Image img = render_error_map(p, t, e, o);
  // The front square spans the middle third of the picture.
  const auto left = img.at(70, 100), right = img.at(130, 100), back = img.at(20, 100), corner = img.at(1, 1);
  CHECK(left[2] > left[0]);
  CHECK(right[0] > right[2]);
  CHECK(back[0] > back[2]);  // the back square, red, where the front one does not cover it
  CHECK(corner == std::array<std::uint8_t, 3>{255, 255, 255});
  CHECK_THROWS_AS(render_error_map(p, t, std::vector<float>(3), o), gatcore::InvalidArgument);
}

TEST_CASE("PNG files round-trip; pictures of a deformed tube and a loss curve", "[character][render]") {
  const auto dir = charfix::temp_dir();
  std::filesystem::create_directories(dir);
  Image img;
  img.width = 300;
  img.height = 250;  // > 65535 bytes of scanlines: several deflate blocks
  for (int i = 0; i < img.width * img.height * 3; ++i) img.rgb.push_back(static_cast<std::uint8_t>(i * 7));
  write_png((dir / "pattern.png").string(), img);
  const Image back = read_png((dir / "pattern.png").string());
  CHECK(back.width == 300);
  CHECK(back.height == 250);
  CHECK(back.rgb == img.rgb);
  CHECK_THROWS_WITH(write_png("/nonexistent/dir/x.png", img), Catch::Matchers::Contains("/nonexistent/dir/x.png"));

  const Character ch = charfix::tube_character(32, 24);
  Pose pose = rest_pose(ch.skeleton);
  pose.local[1].rotation = quat_from_axis_angle({0.0f, 0.0f, 1.0f}, 1.2f);
  const auto S = skinning_matrices(ch.skeleton, pose);
  const auto lbs = linear_blend_skinning(ch.mesh, S), dqs = dual_quaternion_skinning(ch.mesh, S);
  std::vector<float> err(static_cast<std::size_t>(ch.mesh.num_vertices()));
  for (std::size_t v = 0; v < err.size(); ++v)
    err[v] = std::sqrt(std::pow(lbs[3 * v] - dqs[3 * v], 2.0f) + std::pow(lbs[3 * v + 1] - dqs[3 * v + 1], 2.0f) +
                       std::pow(lbs[3 * v + 2] - dqs[3 * v + 2], 2.0f));
  const Image map = render_error_map(lbs, ch.mesh.triangles, err);
  write_png((dir / "tube_lbs_vs_dqs.png").string(), map);
  CHECK(read_png((dir / "tube_lbs_vs_dqs.png").string()).rgb == map.rgb);
  int coloured = 0;
  for (std::size_t i = 0; i < map.rgb.size(); i += 3) coloured += !(map.rgb[i] == 255 && map.rgb[i + 1] == 255 && map.rgb[i + 2] == 255);
  CHECK(coloured > 5000);
  const Image curve = plot_curves({{1.0f, 0.5f, 0.2f, 0.1f, 0.05f}, {1.2f, 0.7f, 0.4f, 0.3f, 0.3f}});
  write_png((dir / "loss.png").string(), curve);
  CHECK(curve.width == 640);
}
