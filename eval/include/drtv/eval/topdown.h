// drtv/eval/topdown.h — a top-down picture of a World, to look at what a world file or the
// island generator made: surfaces shaded by slope, anything below sea level (z < 0) under water, objects in their albedo tinted by
// class, interiors outlined, and the 64 m sector grid.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/image/image.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {

struct TopDownOptions {
  int max_size_px = 1024;     // the longer side of the image, pixels
  bool sector_grid = true;    // draw the 64 m sector lines
  bool interiors = true;      // outline interior volumes in yellow
};

// Rasterises every instance's triangles from above with a z-buffer (highest surface wins) and
// Lambert shading under a light from the north-west. Deterministic; single-threaded; O(pixels +
// triangles). An empty world gives a 1x1 black image.
image::RgbImage renderTopDown(const worlds::World& world, const TopDownOptions& options = {});

}  // namespace drtv::eval
