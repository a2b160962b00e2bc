// A tiny RGB8 canvas for the fly report's PNGs: rectangles, lines, a 3x5 digit font, and a
// PNG writer (stb_image_write, compiled static in canvas.cpp). Private to the streamer.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "drtv/formats/error.h"

namespace drtv::streamer::detail {

struct Rgb {
  uint8_t r = 0, g = 0, b = 0;
};

class Canvas {
 public:
  Canvas(int width, int height, Rgb background);
  int width() const { return w_; }
  int height() const { return h_; }
  void set(int x, int y, Rgb c);  // clipped
  void fill(int x0, int y0, int x1, int y1, Rgb c);  // [x0, x1) x [y0, y1), clipped
  void rect(int x0, int y0, int x1, int y1, Rgb c);  // outline
  void line(double x0, double y0, double x1, double y1, Rgb c, bool dashed = false);
  // Digits, '.', '-', 'k', 'M', 'm', 's', '%' and space, 3x5 pixels scaled by `scale`.
  void text(int x, int y, const std::string& s, Rgb c, int scale = 2);
  const std::vector<uint8_t>& pixels() const { return px_; }
  std::vector<uint8_t>& pixels() { return px_; }

 private:
  int w_, h_;
  std::vector<uint8_t> px_;
};

// Writes RGB8 pixels as PNG. Error names the file.
Result<void> writePng(const std::filesystem::path& path, int width, int height, const std::vector<uint8_t>& rgb);

// A line plot of `ys` (one value per frame) with horizontal reference lines, axis ticks labelled
// with the digit font. Titles and units are the report's job (Markdown).
struct RefLine {
  double y = 0;
  Rgb colour;
};
Canvas linePlot(const std::vector<double>& ys, Rgb colour, const std::vector<RefLine>& refs, double y_max, int width = 900,
                int height = 320);

}  // namespace drtv::streamer::detail
