// The report canvas (canvas.h). stb_image_write's symbols stay static to this file.
#include "canvas.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include <stb/stb_image_write.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace drtv::streamer::detail {
namespace {

// 3x5 glyphs, one row per 3-bit group (MSB = left), top row first.
uint16_t glyph(char c) {
  switch (c) {
    case '0': return 0b111'101'101'101'111;
    case '1': return 0b010'110'010'010'111;
    case '2': return 0b111'001'111'100'111;
    case '3': return 0b111'001'111'001'111;
    case '4': return 0b101'101'111'001'001;
    case '5': return 0b111'100'111'001'111;
    case '6': return 0b111'100'111'101'111;
    case '7': return 0b111'001'010'010'010;
    case '8': return 0b111'101'111'101'111;
    case '9': return 0b111'101'111'001'111;
    case '.': return 0b000'000'000'000'010;
    case '-': return 0b000'000'111'000'000;
    case 'k': return 0b100'101'110'101'101;
    case 'M': return 0b101'111'111'101'101;
    case 'm': return 0b000'000'111'111'101;
    case 's': return 0b000'011'110'011'110;
    case '%': return 0b101'001'010'100'101;
    default: return 0;
  }
}

}  // namespace

Canvas::Canvas(int w, int h, Rgb bg) : w_(w), h_(h), px_(size_t(w) * size_t(h) * 3) {
  for (size_t i = 0; i < px_.size(); i += 3) {
    px_[i] = bg.r;
    px_[i + 1] = bg.g;
    px_[i + 2] = bg.b;
  }
}

void Canvas::set(int x, int y, Rgb c) {
  if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
  uint8_t* p = &px_[(size_t(y) * size_t(w_) + size_t(x)) * 3];
  p[0] = c.r;
  p[1] = c.g;
  p[2] = c.b;
}

void Canvas::fill(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y < std::min(h_, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(w_, x1); ++x) set(x, y, c);
}

void Canvas::rect(int x0, int y0, int x1, int y1, Rgb c) {
  line(x0, y0, x1, y0, c);
  line(x1, y0, x1, y1, c);
  line(x1, y1, x0, y1, c);
  line(x0, y1, x0, y0, c);
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, bool dashed) {
  const double len = std::max(std::abs(x1 - x0), std::abs(y1 - y0));
  const int n = std::max(1, int(std::ceil(len)));
  for (int i = 0; i <= n; ++i) {
    if (dashed && (i / 6) % 2) continue;
    const double t = double(i) / n;
    set(int(std::lround(x0 + (x1 - x0) * t)), int(std::lround(y0 + (y1 - y0) * t)), c);
  }
}

void Canvas::text(int x, int y, const std::string& s, Rgb c, int scale) {
  for (char ch : s) {
    const uint16_t g = glyph(ch);
    for (int row = 0; row < 5; ++row)
      for (int col = 0; col < 3; ++col)
        if (g >> (14 - (row * 3 + col)) & 1) fill(x + col * scale, y + row * scale, x + (col + 1) * scale, y + (row + 1) * scale, c);
    x += 4 * scale;
  }
}

Result<void> writePng(const std::filesystem::path& path, int w, int h, const std::vector<uint8_t>& rgb) {
  if (!stbi_write_png(path.c_str(), w, h, 3, rgb.data(), w * 3)) return fail(path.string() + ": cannot write PNG");
  return {};
}

Canvas linePlot(const std::vector<double>& ys, Rgb colour, const std::vector<RefLine>& refs, double y_max, int width, int height) {
  Canvas c(width, height, {255, 255, 255});
  const int left = 70, right = width - 10, top = 10, bottom = height - 30;
  if (!(y_max > 0)) y_max = 1;
  auto py = [&](double y) { return bottom - (bottom - top) * std::clamp(y / y_max, 0.0, 1.05); };
  const size_t n = std::max<size_t>(ys.size(), 2);
  auto px = [&](double i) { return left + (right - left) * i / double(n - 1); };
  // Grid: 5 horizontal divisions labelled with their value, 10 vertical ones labelled by frame.
  for (int k = 0; k <= 5; ++k) {
    const double y = y_max * k / 5;
    c.line(left, py(y), right, py(y), {225, 225, 225});
    char buf[32];
    std::snprintf(buf, sizeof buf, y_max >= 100 ? "%.0f" : y_max >= 10 ? "%.1f" : "%.2f", y);
    c.text(4, int(py(y)) - 5, buf, {60, 60, 60});
  }
  for (int k = 0; k <= 10; ++k) {
    const double i = double(n - 1) * k / 10;
    c.line(px(i), top, px(i), bottom, {235, 235, 235});
    const std::string label = std::to_string(int(std::lround(i)));
    c.text(std::min(int(px(i)) - 8, width - 2 - 8 * int(label.size())), bottom + 8, label, {60, 60, 60});
  }
  c.rect(left, top, right, bottom, {120, 120, 120});
  for (const RefLine& r : refs) c.line(left, py(r.y), right, py(r.y), r.colour, true);
  for (size_t i = 1; i < ys.size(); ++i) c.line(px(double(i - 1)), py(ys[i - 1]), px(double(i)), py(ys[i]), colour);
  if (ys.size() == 1) c.set(int(px(0)), int(py(ys[0])), colour);
  return c;
}

}  // namespace drtv::streamer::detail
