// drtv/image/image.h — the one image and plot module: an 8-bit RGB image, its PNG writer
// (stb_image_write, compiled static in image.cpp), and a canvas with the primitives the reports
// draw: rectangles, lines, two pixel fonts, line plots. Used by the fly-through's report, the
// accuracy plot, the preview renders and the world map.
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

// An 8-bit sRGB image, rows top to bottom, 3 bytes a pixel.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // width * height * 3
  void set(int x, int y, uint8_t r, uint8_t g, uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    uint8_t* p = &pixels[(size_t(y) * width + x) * 3];
    p[0] = r, p[1] = g, p[2] = b;
  }
};

// An image `width` x `height` filled with `colour`.
RgbImage blankImage(int width, int height, Rgb colour = {0, 0, 0});

// Writes `image` as a PNG. Errors name the path.
Result<void> writePng(const std::filesystem::path& path, const RgbImage& image);

// Drawing on an RgbImage; every primitive clips.
class Canvas {
 public:
  Canvas(int width, int height, Rgb background);
  int width() const { return img_.width; }
  int height() const { return img_.height; }
  void set(int x, int y, Rgb c);
  void fill(int x0, int y0, int x1, int y1, Rgb c);  // [x0, x1) x [y0, y1)
  void rect(int x0, int y0, int x1, int y1, Rgb c);  // outline through both corners
  void line(double x0, double y0, double x1, double y1, Rgb c, bool dashed = false);
  // Digits, '.', '-', 'k', 'M', 'm', 's', '%' and space, 3x5 pixels scaled by `scale`.
  void digits(int x, int y, const std::string& s, Rgb c, int scale = 2);
  // Upper-case letters, digits and punctuation, 5x7 pixels scaled by `scale` (lower case is drawn
  // upper case). Returns the width drawn.
  int text(int x, int y, const std::string& s, Rgb c = {0, 0, 0}, int scale = 1);
  const RgbImage& image() const { return img_; }
  RgbImage take() { return std::move(img_); }

 private:
  RgbImage img_;
};

// A line plot of `ys` (one value per frame) with horizontal reference lines, axis ticks labelled
// with the digit font. Titles and units are the report's job (Markdown).
struct RefLine {
  double y = 0;
  Rgb colour;
};
Canvas linePlot(const std::vector<double>& ys, Rgb colour, const std::vector<RefLine>& refs, double y_max, int width = 900,
                int height = 320);

}  // namespace drtv::image
