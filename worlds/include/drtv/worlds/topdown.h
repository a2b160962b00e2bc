// drtv/worlds/topdown.h — a top-down picture of a World, to look at what a world file or the
// island generator made: surfaces shaded by slope, anything below sea level (z < 0) under water, objects in their albedo tinted by
// class, interiors outlined, and the 64 m sector grid.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

// An 8-bit sRGB image, rows top (north, +Y) to bottom, 3 bytes a pixel.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // width * height * 3
  void set(int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    uint8_t* p = &pixels[(size_t(y) * width + x) * 3];
    p[0] = r, p[1] = g, p[2] = b;
  }
};

struct TopDownOptions {
  int max_size_px = 1024;     // the longer side of the image, pixels
  bool sector_grid = true;    // draw the 64 m sector lines
  bool interiors = true;      // outline interior volumes in yellow
};

// Rasterises every instance's triangles from above with a z-buffer (highest surface wins) and
// Lambert shading under a light from the north-west. Deterministic; single-threaded; O(pixels +
// triangles). An empty world gives a 1x1 black image.
RgbImage renderTopDown(const World& world, const TopDownOptions& options = {});

// Writes `image` as a PNG. Errors name the path.
Result<void> writePng(const std::filesystem::path& path, const RgbImage& image);

}  // namespace drtv::worlds
