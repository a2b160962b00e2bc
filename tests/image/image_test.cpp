// Tests of drtv::image (image.h): every primitive clips, the fonts' advance, the plot's breaks and
// the PNG writer, whose file is decoded again by stb_image (an independent reader).
#include "drtv/image/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#endif
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace drtv::image {
namespace {

constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kRed{200, 10, 20};

Rgb at(const RgbImage& img, int x, int y) {
  const uint8_t* p = &img.pixels[(size_t(y) * img.width + x) * 3];
  return {p[0], p[1], p[2]};
}
bool same(Rgb a, Rgb b) { return a.r == b.r && a.g == b.g && a.b == b.b; }
size_t count(const RgbImage& img, Rgb c) {
  size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) n += same(at(img, x, y), c);
  return n;
}

TEST(Image, ABlankImageHasEveryPixelInTheColour) {
  const RgbImage img = blankImage(7, 5, {1, 2, 3});
  ASSERT_EQ(img.pixels.size(), 7u * 5u * 3u);
  EXPECT_EQ(count(img, {1, 2, 3}), 35u);
}

TEST(Image, ABlankImageOfZeroSideHasNoPixels) {
  EXPECT_TRUE(blankImage(0, 9).pixels.empty());
  EXPECT_TRUE(blankImage(9, 0).pixels.empty());
}

TEST(ImageDeathTest, ANegativeSideIsABug) {
  EXPECT_DEATH(blankImage(-1, 4), "internal error");
  EXPECT_DEATH(blankImage(4, kMaxImageSide + 1), "internal error");
}

TEST(Canvas, SettingAPixelOutsideChangesNothing) {
  Canvas c(4, 4, kWhite);
  for (auto [x, y] : {std::pair{-1, 0}, {0, -1}, {4, 0}, {0, 4}, {-100000, 100000}}) c.set(x, y, kRed);
  EXPECT_EQ(count(c.image(), kWhite), 16u);
  c.set(3, 3, kRed);
  EXPECT_TRUE(same(at(c.image(), 3, 3), kRed));
}

TEST(Canvas, FillClipsToTheImage) {
  Canvas c(10, 10, kWhite);
  c.fill(-5, -5, 2, 3, kRed);  // [x0, x1) x [y0, y1): 2 columns, 3 rows inside
  EXPECT_EQ(count(c.image(), kRed), 6u);
  EXPECT_TRUE(same(at(c.image(), 1, 2), kRed));
  EXPECT_TRUE(same(at(c.image(), 2, 2), kWhite));
  c.fill(8, 8, 100, 100, kRed);
  EXPECT_EQ(count(c.image(), kRed), 10u);
}

TEST(Canvas, ALineIncludesBothEndpoints) {
  Canvas c(20, 20, kWhite);
  c.line(2, 3, 12, 8, kRed);
  EXPECT_TRUE(same(at(c.image(), 2, 3), kRed));
  EXPECT_TRUE(same(at(c.image(), 12, 8), kRed));
  EXPECT_EQ(count(c.image(), kRed), 11u);  // one pixel a column along the longer axis
}

TEST(Canvas, ALineFarOutsideSetsTheSamePixelsAsItsVisiblePart) {
  // The same straight line, once between two points in the image and once reaching 1e12 pixels
  // past both sides: the pixels inside must agree, and the long one must not walk 1e12 steps.
  Canvas near(64, 64, kWhite), far(64, 64, kWhite);
  near.line(0, 10, 63, 10, kRed);
  far.line(-1e12, 10, 1e12, 10, kRed);
  EXPECT_EQ(count(near.image(), kRed), 64u);
  EXPECT_EQ(near.image().pixels, far.image().pixels);
  Canvas diagonal(64, 64, kWhite);
  diagonal.line(-1e9, -1e9, 1e9, 1e9, kRed);
  EXPECT_EQ(count(diagonal.image(), kRed), 64u);
  for (int i = 0; i < 64; ++i) EXPECT_TRUE(same(at(diagonal.image(), i, i), kRed)) << i;
}

TEST(Canvas, ALineWithANonFiniteEndDrawsNothing) {
  Canvas c(8, 8, kWhite);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  c.line(0, 0, nan, 4, kRed);
  c.line(0, 0, 4, inf, kRed);
  c.line(-inf, 2, inf, 2, kRed);
  EXPECT_EQ(count(c.image(), kRed), 0u);
}

TEST(Canvas, ADashedLineIsSixOnSixOff) {
  Canvas c(30, 3, kWhite);
  c.line(0, 1, 29, 1, kRed, /*dashed=*/true);
  for (int x = 0; x < 30; ++x) EXPECT_EQ(same(at(c.image(), x, 1), kRed), (x / 6) % 2 == 0) << x;
}

TEST(Canvas, ARectIsAnOutlineThroughBothCorners) {
  Canvas c(10, 10, kWhite);
  c.rect(2, 2, 6, 5, kRed);
  EXPECT_EQ(count(c.image(), kRed), 2u * 5u + 2u * 2u);  // rows of 5, columns of 4 less the corners
  EXPECT_TRUE(same(at(c.image(), 4, 3), kWhite));
}

TEST(Canvas, TextAdvancesSixPixelsACharacterAndDrawsLowerCaseAsUpper) {
  Canvas upper(80, 20, kWhite), lower(80, 20, kWhite);
  EXPECT_EQ(upper.text(1, 1, "AB 1%", kRed, 2), 6 * 2 * 5);
  EXPECT_EQ(lower.text(1, 1, "ab 1%", kRed, 2), 6 * 2 * 5);
  EXPECT_EQ(upper.image().pixels, lower.image().pixels);
  EXPECT_GT(count(upper.image(), kRed), 0u);
  Canvas unknown(20, 20, kWhite);
  EXPECT_EQ(unknown.text(0, 0, "~", kRed), 6);  // no glyph: a space
  EXPECT_EQ(count(unknown.image(), kRed), 0u);
}

TEST(Canvas, DigitsDrawTheirThreeByFiveGlyphs) {
  Canvas c(3, 5, kWhite);
  c.digits(0, 0, "1", kRed, 1);
  // '1' is 010 / 110 / 010 / 010 / 111.
  const char* rows[5] = {".#.", "##.", ".#.", ".#.", "###"};
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 3; ++x) EXPECT_EQ(same(at(c.image(), x, y), kRed), rows[y][x] == '#') << x << "," << y;
}

TEST(LinePlot, ANonFiniteValueBreaksTheLine) {
  const Rgb series{0, 0, 250};  // a colour the plot's grid and labels never use
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(count(linePlot({nan, nan, nan}, series, {}, 1.0).image(), series), 0u);
  // Two finite frames with a break between them: a dot each, no segment.
  EXPECT_EQ(count(linePlot({0.5, nan, 0.5}, series, {}, 1.0).image(), series), 2u);
  // Without the break the line joins them across the plot.
  EXPECT_GT(count(linePlot({0.5, 0.5, 0.5}, series, {}, 1.0).image(), series), 100u);
  // A non-finite or non-positive scale falls back to 1, as documented.
  EXPECT_EQ(linePlot({0.5, 0.5}, series, {}, nan).image().pixels, linePlot({0.5, 0.5}, series, {}, 1.0).image().pixels);
}

TEST(LinePlot, IsTheSizeAskedFor) {
  const Canvas c = linePlot({1, 2, 3}, kRed, {{1.5, {0, 200, 0}}}, 4.0, 300, 120);
  EXPECT_EQ(c.width(), 300);
  EXPECT_EQ(c.height(), 120);
  EXPECT_GT(count(c.image(), {0, 200, 0}), 50u);  // the dashed reference line
}

TEST(WritePng, AnImageDecodesToTheSameBytes) {
  RgbImage img = blankImage(13, 7, {9, 8, 7});
  for (int y = 0; y < 7; ++y)
    for (int x = 0; x < 13; ++x) img.set(x, y, uint8_t(x * 19), uint8_t(y * 37), uint8_t(x * y));
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "drtv_image_test.png";
  ASSERT_TRUE(writePng(path, img).has_value());
  int w = 0, h = 0, channels = 0;
  unsigned char* decoded = stbi_load(path.c_str(), &w, &h, &channels, 3);
  ASSERT_NE(decoded, nullptr) << stbi_failure_reason();
  EXPECT_EQ(w, 13);
  EXPECT_EQ(h, 7);
  EXPECT_EQ(channels, 3);
  EXPECT_EQ(std::vector<uint8_t>(decoded, decoded + img.pixels.size()), img.pixels);
  stbi_image_free(decoded);
  std::filesystem::remove(path);
}

TEST(WritePng, NamesThePathWhenItCannotWrite) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "drtv-no-such-folder" / "x.png";
  const auto r = writePng(path, blankImage(2, 2));
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find(path.string()), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("No such file"), std::string::npos) << r.error().message;
}

TEST(WritePng, RefusesAnImageWithoutPixelsOrWithTheWrongCount) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "drtv_image_empty.png";
  EXPECT_FALSE(writePng(path, blankImage(0, 3)).has_value());
  RgbImage wrong = blankImage(4, 4);
  wrong.pixels.pop_back();
  const auto r = writePng(path, wrong);
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find(path.string()), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
}  // namespace drtv::image
