// The visibility maps of covered probes (visibility.h): the octahedral map, the texel encoding,
// and the test of a point against a wall.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "drtv/formats/visibility.h"

namespace drtv {
namespace {

TEST(Visibility, TheOctahedralMapRoundTripsEveryDirection) {
  for (int i = 0; i < 2000; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / 2000.0, r = std::sqrt(1.0 - z * z), phi = 2.399963229728653 * i;
    const glm::vec3 d(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
    const glm::vec2 uv = octEncode(d);
    EXPECT_TRUE(uv.x >= 0.f && uv.x <= 1.f && uv.y >= 0.f && uv.y <= 1.f);
    EXPECT_LT(glm::length(octDecode(uv) - d), 1e-5f) << i;
  }
  // Z up: the upper hemisphere is the inner diamond, the zenith its centre.
  EXPECT_LT(glm::length(octEncode({0, 0, 1}) - glm::vec2(0.5f)), 1e-6f);
  for (int y = 0; y < kVisDim; ++y)
    for (int x = 0; x < kVisDim; ++x) {
      const glm::vec2 t = octEncode(visTexelDirection(x, y)) * float(kVisDim);
      EXPECT_EQ(int(t.x), x);
      EXPECT_EQ(int(t.y), y);
    }
}

TEST(Visibility, ATexelKeepsItsMeanAndDeviationWithinASmallStep) {
  for (double mean : {0.05, 0.5, 1.0, 2.5, 7.0, 15.9})
    for (double sigma : {0.0, 0.03, 0.4, 3.0}) {
      const auto q = encodeVisTexel(mean, sigma);
      const glm::vec2 back = decodeVisTexel(q[0], q[1]);
      // sqrt steps: d(mean) = 2 sqrt(mean R) / 255 / 2, at most 6.3 cm at 16 m.
      EXPECT_NEAR(back.x, mean, std::sqrt(mean * kVisRangeM) / 255.0 + 1e-6) << mean;
      EXPECT_NEAR(back.y, sigma, kVisMaxSigmaM / 510.0 + 1e-6) << sigma;
    }
  const auto far = encodeVisTexel(100.0, 100.0);  // clamped to the range
  EXPECT_EQ(far[0], 255);
  EXPECT_EQ(far[1], 255);
}

// A probe 2 m from a flat ceiling (every texel of the upper hemisphere sees it at 2 / cos): a point
// under the ceiling sees the probe, one 0.3 m above it (a room above, a roof's top) does not.
TEST(Visibility, APointBeyondTheCeilingIsNotSeenAndOneBelowIs) {
  std::vector<uint8_t> map(kVisBytesPerProbe);
  for (int y = 0; y < kVisDim; ++y)
    for (int x = 0; x < kVisDim; ++x) {
      const glm::vec3 c = visTexelDirection(x, y);
      const double d = c.z > 0.05f ? std::min(2.0 / c.z, double(kVisRangeM)) : double(kVisRangeM);
      const auto q = encodeVisTexel(d, 0.02 * d);
      map[size_t(y * kVisDim + x) * 2] = q[0], map[size_t(y * kVisDim + x) * 2 + 1] = q[1];
    }
  for (const glm::vec3 dir : {glm::vec3(0, 0, 1), glm::normalize(glm::vec3(0.3f, 0.2f, 1.f)), glm::normalize(glm::vec3(-0.5f, 0.4f, 1.f))}) {
    const float to_ceiling = 2.f / dir.z;
    EXPECT_EQ(visibilityWeight(map, dir, 0.9f * to_ceiling), 1.f);
    // (Under the runtime's cut, FineOptions::min_visibility 0.1: the ceiling's depth changes across
    // the texels read, which Chebyshev's bound takes for spread.)
    EXPECT_LT(visibilityWeight(map, dir, (2.3f + 0.1f) / dir.z), 0.05f) << dir.x;
  }
  // Sideways, nothing within range: seen.
  EXPECT_EQ(visibilityWeight(map, {1, 0, 0}, 10.f), 1.f);
}

}  // namespace
}  // namespace drtv
