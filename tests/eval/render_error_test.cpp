// The render's error figures (render.h, errorFigures): per pixel and in blocks. A reference's
// noise inflates the per-pixel mean |error| and bias of an engine that is right on average; the
// blocks' figures see through it, and still see an engine that is wrong over an area.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "drtv/eval/render.h"

namespace drtv::eval {
namespace {

constexpr int kWidth = 64, kHeight = 48, kBlock = 8;
constexpr double kFloor = 1e-3;

struct Images {
  std::vector<glm::vec3> preview, reference;
  std::vector<double> std_error;
  std::vector<uint8_t> hit;
};

// A grey image of luminance 1 everywhere (grey: luminance = the channel), every pixel hit, and a
// reference equal to it.
Images flat() {
  const size_t n = size_t(kWidth) * kHeight;
  return {std::vector<glm::vec3>(n, glm::vec3(1.f)), std::vector<glm::vec3>(n, glm::vec3(1.f)), std::vector<double>(n, 0.0),
          std::vector<uint8_t>(n, 1)};
}

ErrorFigures figures(const Images& im, int block) {
  return errorFigures(im.preview, im.reference, im.std_error, im.hit, kWidth, block, kFloor);
}

TEST(RenderError, AnEngineEqualToItsReferenceReadsZeroPerPixelAndInBlocks) {
  const Images im = flat();
  for (int block : {1, kBlock}) {
    const ErrorFigures f = figures(im, block);
    EXPECT_EQ(f.abs_rel, 0.0);
    EXPECT_EQ(f.rel, 0.0);
    EXPECT_EQ(f.noise, 0.0);
  }
  EXPECT_EQ(figures(im, 1).blocks, size_t(kWidth) * kHeight);
  EXPECT_EQ(figures(im, kBlock).blocks, size_t(kWidth / kBlock) * (kHeight / kBlock));
}

// A reference with 40 % noise about the engine's (right) value: per pixel the engine reads tens
// of percent wrong and biased bright; in blocks of 64 pixels, within a few percent.
TEST(RenderError, AReferencesNoiseInflatesThePixelsFiguresAndNotTheBlocks) {
  Images im = flat();
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.4);
  for (size_t i = 0; i < im.reference.size(); ++i) {
    im.reference[i] = glm::vec3(float(std::max(0.05, 1.0 + noise(rng))));
    im.std_error[i] = 0.4;
  }
  const ErrorFigures px = figures(im, 1), bl = figures(im, kBlock);
  EXPECT_GT(px.abs_rel, 0.25);
  EXPECT_GT(px.rel, 0.1);  // E[1 / X] > 1 / E[X]
  EXPECT_GT(px.noise, 0.4);  // the standard error over a noisy reference: inflated as well
  EXPECT_LT(bl.abs_rel, 0.08);
  EXPECT_LT(std::abs(bl.rel), 0.03);
  EXPECT_NEAR(bl.noise, 0.05, 0.01);  // 0.4 / sqrt(64)
}

// An engine 20 % too bright over the left half reads so in both: the blocks keep what is wrong
// over an area. A block less than half hit is not counted.
TEST(RenderError, AnAreaTooBrightReadsSoInBlocksAndHalfEmptyBlocksAreLeftOut) {
  Images im = flat();
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth / 2; ++x) im.preview[size_t(y) * kWidth + size_t(x)] = glm::vec3(1.2f);
  const ErrorFigures px = figures(im, 1), bl = figures(im, kBlock);
  EXPECT_NEAR(px.rel, 0.1, 1e-6);
  EXPECT_NEAR(bl.rel, 0.1, 1e-6);
  EXPECT_NEAR(bl.abs_rel, 0.1, 1e-6);
  // The first block row: 5 of 8 rows missed (sky) in every block: left out.
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < kWidth; ++x) im.hit[size_t(y) * kWidth + size_t(x)] = 0;
  EXPECT_EQ(figures(im, kBlock).blocks, size_t(kWidth / kBlock) * (kHeight / kBlock - 1));
  // Nothing hit: no figure.
  std::fill(im.hit.begin(), im.hit.end(), uint8_t(0));
  EXPECT_TRUE(std::isnan(figures(im, kBlock).abs_rel));
  EXPECT_EQ(figures(im, kBlock).blocks, 0u);
}

}  // namespace
}  // namespace drtv::eval
