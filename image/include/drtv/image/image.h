// drtv/image/image.h — the one image and plot module: an 8-bit RGB image, its PNG writer
// (stb_image_write, compiled static in image.cpp, so its symbols never clash with an engine's
// copy), and a canvas with the primitives the reports draw: rectangles, lines, two pixel fonts,
// line plots. Used by the fly-through's report, the accuracy plot, the preview renders and the
// world map. Tests: tests/image/image_test.cpp.
//
// Coordinates are pixels: x to the right, y down, (0, 0) the top-left pixel's centre. Colours are
// 8-bit sRGB-encoded values as they go into the PNG (callers tone-map and encode linear light
// themselves). Every drawing primitive clips to the image: coordinates outside it, however far,
// draw nothing there and cost no more than the part inside; non-finite coordinates draw nothing.
//
// Thread-safety: none of its own. Distinct images may be drawn and written from distinct threads
// at once; one image from one thread at a time.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "drtv/formats/error.h"

namespace drtv::image {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

// An 8-bit sRGB image, rows top to bottom, 3 bytes a pixel (R, G, B), no padding between rows.
// Invariant (blankImage keeps it; code that fills `pixels` itself must): pixels.size() ==
// width * height * 3.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // width * height * 3
  // Sets pixel (x, y); a pixel outside the image is ignored.
  void set(int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    uint8_t* p = &pixels[(size_t(y) * width + x) * 3];
    p[0] = r, p[1] = g, p[2] = b;
  }
};

// The largest side blankImage and Canvas take: 32,768 pixels (a 32k x 32k image is 3 GiB).
inline constexpr int kMaxImageSide = 1 << 15;

// An image `width` x `height` filled with `colour`. Precondition (a bug if broken, checked):
// 0 <= width, height <= kMaxImageSide. A side of 0 gives an image with no pixels, which writePng
// refuses.
RgbImage blankImage(int width, int height, Rgb colour = {0, 0, 0});

// Writes `image` as an 8-bit RGB PNG at `path` (overwritten if it exists; the folder must exist).
// Errors, naming the path: an image with no pixels or whose pixel count breaks the invariant
// above, and a file that cannot be written (with the system's reason). Thread-safe for distinct
// paths.
Result<void> writePng(const std::filesystem::path& path, const RgbImage& image);

// Drawing on an RgbImage; every primitive clips (see the top of this file).
class Canvas {
 public:
  // A `width` x `height` canvas filled with `background` (blankImage's precondition).
  Canvas(int width, int height, Rgb background);
  int width() const { return img_.width; }
  int height() const { return img_.height; }
  void set(int x, int y, Rgb c);
  void fill(int x0, int y0, int x1, int y1, Rgb c);  // [x0, x1) x [y0, y1)
  void rect(int x0, int y0, int x1, int y1, Rgb c);  // outline through both corners
  // A one-pixel line through both endpoints (pixel centres rounded to nearest), both included;
  // dashed: 6 pixels on, 6 off, from (x0, y0).
  void line(double x0, double y0, double x1, double y1, Rgb c, bool dashed = false);
  // Digits, '.', '-', 'k', 'M', 'm', 's', '%' and space, 3x5 pixels scaled by `scale`, 4 x scale
  // pixels a character, (x, y) the first glyph's top-left; other characters draw as a space.
  void digits(int x, int y, const std::string& s, Rgb c, int scale = 2);
  // Upper-case letters, digits and punctuation ".,-+%/():=_[]", 5x7 pixels scaled by `scale`,
  // 6 x scale pixels a character (lower case is drawn upper case; other characters as a space).
  // Returns the width advanced: 6 x scale x s.size().
  int text(int x, int y, const std::string& s, Rgb c = {0, 0, 0}, int scale = 1);
  const RgbImage& image() const { return img_; }
  RgbImage take() { return std::move(img_); }

 private:
  RgbImage img_;
};

// A line plot of `ys` (one value per frame, frame i at x = i) on a white `width` x `height`
// canvas: a grid of 5 labelled horizontal and 10 labelled vertical divisions, `refs` as dashed
// horizontal lines, and the series in `colour`, its y axis from 0 to `y_max` (<= 0 or NaN: 1;
// values above it are drawn just over the top, 1.05 y_max). A non-finite value (a frame without
// a figure) breaks the line: the segments either side of it are not drawn, and a finite value
// between two breaks is drawn as a dot. Titles and units are the report's job (Markdown).
struct RefLine {
  double y = 0;
  Rgb colour;
};
Canvas linePlot(const std::vector<double>& ys, Rgb colour, const std::vector<RefLine>& refs, double y_max, int width = 900,
                int height = 320);

}  // namespace drtv::image
