// The accuracy sweep's error figures (accuracy.h): relative to the reference, with an absolute
// floor so that a black reference (a sun-only scene with nothing to bounce from) cannot divide by
// ~0 and print errors of 1e33 %.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/eval/accuracy.h"

namespace drtv::baker {
using namespace raytrace;
using namespace eval;
namespace {

// Sums of a few float values: double accumulation, float inputs.
constexpr double kSumTolerance = 1e-6;

TEST(AmbientError, IsTheRelativeL1ErrorOfALitReference) {
  const std::vector<glm::vec3> reference{glm::vec3(1.f), glm::vec3(2.f)};
  const std::vector<glm::vec3> values{glm::vec3(1.1f), glm::vec3(1.8f)};
  const AmbientError e = ambientError(values, reference);
  EXPECT_FALSE(e.floored);
  EXPECT_NEAR(e.rel, (3 * 0.1 + 3 * 0.2) / 9.0, kSumTolerance);
  EXPECT_NEAR(e.bias, (3 * 0.1 - 3 * 0.2) / 9.0, kSumTolerance);
  EXPECT_NEAR(e.abs, (3 * 0.1 + 3 * 0.2) / 6.0, kSumTolerance);
}

TEST(AmbientError, IsRelativeToTheFloorWhenTheReferenceIsBlack) {
  const std::vector<glm::vec3> reference(10, glm::vec3(0.f));
  const std::vector<glm::vec3> values(10, glm::vec3(0.002f));
  const AmbientError e = ambientError(values, reference);
  EXPECT_TRUE(e.floored);
  EXPECT_TRUE(std::isfinite(e.rel));
  EXPECT_NEAR(e.rel, 0.002 / kAmbientErrorFloor, kSumTolerance);  // twice the floor: 200 %, not 1e33 %
  EXPECT_NEAR(e.bias, 0.002 / kAmbientErrorFloor, kSumTolerance);
  EXPECT_NEAR(e.abs, 0.002, kSumTolerance);
}

TEST(AmbientError, IsZeroForAnExactBlackAnswerAndForNoValues) {
  const std::vector<glm::vec3> black(4, glm::vec3(0.f));
  const AmbientError e = ambientError(black, black);
  EXPECT_EQ(e.rel, 0.0);
  EXPECT_EQ(e.abs, 0.0);
  const AmbientError none = ambientError({}, {});
  EXPECT_EQ(none.rel, 0.0);
  EXPECT_EQ(none.abs, 0.0);
}

}  // namespace
}  // namespace drtv::baker
