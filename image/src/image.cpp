// The image module (image.h). stb_image_write's symbols stay static to this file.
#include "drtv/image/image.h"

#include <algorithm>
#include <cmath>
#include <array>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>

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

namespace drtv::image {
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

// 5x7 glyphs, one row per byte, bit 4 the leftmost column.
const std::map<char, std::array<uint8_t, 7>>& font() {
  static const std::map<char, std::array<uint8_t, 7>> f = {
      {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}}, {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
      {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}}, {'3', {0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e}},
      {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}}, {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
      {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}}, {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
      {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}}, {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
      {'A', {0x0e, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11}}, {'B', {0x1e, 0x11, 0x11, 0x1e, 0x11, 0x11, 0x1e}},
      {'C', {0x0e, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0e}}, {'D', {0x1c, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1c}},
      {'E', {0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x1f}}, {'F', {0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x10}},
      {'G', {0x0e, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0f}}, {'H', {0x11, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11}},
      {'I', {0x0e, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e}}, {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0c}},
      {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}}, {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1f}},
      {'M', {0x11, 0x1b, 0x15, 0x15, 0x11, 0x11, 0x11}}, {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
      {'O', {0x0e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e}}, {'P', {0x1e, 0x11, 0x11, 0x1e, 0x10, 0x10, 0x10}},
      {'Q', {0x0e, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0d}}, {'R', {0x1e, 0x11, 0x11, 0x1e, 0x14, 0x12, 0x11}},
      {'S', {0x0f, 0x10, 0x10, 0x0e, 0x01, 0x01, 0x1e}}, {'T', {0x1f, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
      {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e}}, {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0a, 0x04}},
      {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0a}}, {'X', {0x11, 0x11, 0x0a, 0x04, 0x0a, 0x11, 0x11}},
      {'Y', {0x11, 0x11, 0x11, 0x0a, 0x04, 0x04, 0x04}}, {'Z', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1f}},
      {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}}, {',', {0x00, 0x00, 0x00, 0x00, 0x0c, 0x04, 0x08}},
      {'-', {0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00}}, {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}},
      {'%', {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03}}, {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
      {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}}, {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
      {':', {0x00, 0x0c, 0x0c, 0x00, 0x0c, 0x0c, 0x00}}, {'=', {0x00, 0x00, 0x1f, 0x00, 0x1f, 0x00, 0x00}},
      {'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1f}}, {'[', {0x0e, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0e}},
      {']', {0x0e, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0e}},
  };
  return f;
}

}  // namespace

RgbImage blankImage(int w, int h, Rgb bg) {
  DRTV_CHECK(w >= 0 && h >= 0 && w <= kMaxImageSide && h <= kMaxImageSide);
  RgbImage img;
  img.width = w;
  img.height = h;
  img.pixels.resize(size_t(w) * size_t(h) * 3);
  for (size_t i = 0; i < img.pixels.size(); i += 3) {
    img.pixels[i] = bg.r;
    img.pixels[i + 1] = bg.g;
    img.pixels[i + 2] = bg.b;
  }
  return img;
}

Canvas::Canvas(int w, int h, Rgb bg) : img_(blankImage(w, h, bg)) {}

void Canvas::set(int x, int y, Rgb c) {
  img_.set(x, y, c.r, c.g, c.b);
}

void Canvas::fill(int x0, int y0, int x1, int y1, Rgb c) {
  for (int y = std::max(0, y0); y < std::min(img_.height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(img_.width, x1); ++x) set(x, y, c);
}

void Canvas::rect(int x0, int y0, int x1, int y1, Rgb c) {
  line(x0, y0, x1, y0, c);
  line(x1, y0, x1, y1, c);
  line(x1, y1, x0, y1, c);
  line(x0, y1, x0, y0, c);
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, bool dashed) {
  if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1)) return;
  const double len = std::max(std::abs(x1 - x0), std::abs(y1 - y0));
  // Steps of at most a pixel along the longer axis; the steps whose point can land in the image
  // (t within the image grown by a pixel, each axis in turn) are the only ones taken, so a line
  // reaching far outside costs what its visible part costs and sets the same pixels.
  if (len > 1e15) return;  // beyond any image: its steps would not fit a counter
  const long long n = std::max<long long>(1, (long long)std::ceil(len));
  double t_lo = 0.0, t_hi = 1.0;
  auto clipAxis = [&](double a0, double a1, double hi) {
    const double lo = -1.0;
    if (a0 == a1) {
      if (a0 < lo || a0 > hi) t_lo = 1.0, t_hi = 0.0;
      return;
    }
    double ta = (lo - a0) / (a1 - a0), tb = (hi - a0) / (a1 - a0);
    if (ta > tb) std::swap(ta, tb);
    t_lo = std::max(t_lo, ta), t_hi = std::min(t_hi, tb);
  };
  clipAxis(x0, x1, double(img_.width));
  clipAxis(y0, y1, double(img_.height));
  if (t_lo > t_hi) return;
  const long long i_lo = std::max<long long>(0, (long long)std::floor(t_lo * double(n)) - 1);
  const long long i_hi = std::min<long long>(n, (long long)std::ceil(t_hi * double(n)) + 1);
  for (long long i = i_lo; i <= i_hi; ++i) {
    if (dashed && (i / 6) % 2) continue;
    const double t = double(i) / n;
    set(int(std::lround(x0 + (x1 - x0) * t)), int(std::lround(y0 + (y1 - y0) * t)), c);
  }
}

void Canvas::digits(int x, int y, const std::string& s, Rgb c, int scale) {
  for (char ch : s) {
    const uint16_t g = glyph(ch);
    for (int row = 0; row < 5; ++row)
      for (int col = 0; col < 3; ++col)
        if (g >> (14 - (row * 3 + col)) & 1) fill(x + col * scale, y + row * scale, x + (col + 1) * scale, y + (row + 1) * scale, c);
    x += 4 * scale;
  }
}

int Canvas::text(int x, int y, const std::string& s, Rgb c, int scale) {
  int cx = x;
  for (char ch : s) {
    const char u = char(std::toupper(static_cast<unsigned char>(ch)));
    if (auto it = font().find(u); it != font().end())
      for (int r = 0; r < 7; ++r)
        for (int col = 0; col < 5; ++col)
          if (it->second[size_t(r)] >> (4 - col) & 1)
            fill(cx + col * scale, y + r * scale, cx + col * scale + scale, y + r * scale + scale, c);
    cx += 6 * scale;
  }
  return cx - x;
}

Result<void> writePng(const std::filesystem::path& path, const RgbImage& image) {
  if (image.width <= 0 || image.height <= 0 || image.pixels.size() != size_t(image.width) * image.height * 3)
    return fail(path.string() + ": image has no pixels");
  errno = 0;
  if (!stbi_write_png(path.c_str(), image.width, image.height, 3, image.pixels.data(), image.width * 3))
    return fail(path.string() + ": cannot write PNG" + (errno ? std::string(": ") + std::strerror(errno) : std::string()));
  return {};
}

Canvas linePlot(const std::vector<double>& ys, Rgb colour, const std::vector<RefLine>& refs, double y_max, int width, int height) {
  Canvas c(width, height, {255, 255, 255});
  const int left = 70, right = width - 10, top = 10, bottom = height - 30;
  if (!(y_max > 0) || !std::isfinite(y_max)) y_max = 1;
  auto py = [&](double y) { return bottom - (bottom - top) * std::clamp(y / y_max, 0.0, 1.05); };
  const size_t n = std::max<size_t>(ys.size(), 2);
  auto px = [&](double i) { return left + (right - left) * i / double(n - 1); };
  // Grid: 5 horizontal divisions labelled with their value, 10 vertical ones labelled by frame.
  for (int k = 0; k <= 5; ++k) {
    const double y = y_max * k / 5;
    c.line(left, py(y), right, py(y), {225, 225, 225});
    char buf[32];
    std::snprintf(buf, sizeof buf, y_max >= 100 ? "%.0f" : y_max >= 10 ? "%.1f" : "%.2f", y);
    c.digits(4, int(py(y)) - 5, buf, {60, 60, 60});
  }
  for (int k = 0; k <= 10; ++k) {
    const double i = double(n - 1) * k / 10;
    c.line(px(i), top, px(i), bottom, {235, 235, 235});
    const std::string label = std::to_string(int(std::lround(i)));
    c.digits(std::min(int(px(i)) - 8, width - 2 - 8 * int(label.size())), bottom + 8, label, {60, 60, 60});
  }
  c.rect(left, top, right, bottom, {120, 120, 120});
  for (const RefLine& r : refs) c.line(left, py(r.y), right, py(r.y), r.colour, true);
  for (size_t i = 1; i < ys.size(); ++i)
    if (std::isfinite(ys[i - 1]) && std::isfinite(ys[i])) c.line(px(double(i - 1)), py(ys[i - 1]), px(double(i)), py(ys[i]), colour);
  // A finite value with no finite neighbour (one frame, or between two breaks) is a dot.
  for (size_t i = 0; i < ys.size(); ++i) {
    const bool before = i > 0 && std::isfinite(ys[i - 1]), after = i + 1 < ys.size() && std::isfinite(ys[i + 1]);
    if (std::isfinite(ys[i]) && !before && !after) c.set(int(px(double(i))), int(py(ys[i])), colour);
  }
  return c;
}

}  // namespace drtv::image
