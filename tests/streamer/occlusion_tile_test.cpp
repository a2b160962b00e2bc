// Occlusion tiles: a slow reference, the empty sector, heights over the terrain.
#include <cmath>

#include <gtest/gtest.h>

#include "drtv/runtime/occlusion.h"
#include "drtv/streamer/occlusion_tile.h"
#include "test_world.h"

namespace drtv::streamer {
namespace {

// unorm8 rounding plus float summation order: one step.
constexpr int kUnorm8Tolerance = 1;

TEST(BuildOcclusionTile, MatchesAGaussianWeightedMeanComputedInDouble) {
  const Sector s = testing::makeSector({3, 4}, 70, 0, 7);
  const OcclusionTile t = buildOcclusionTile(s);
  EXPECT_EQ(t.key, s.key);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      double w = 0, v = 0, h = 0;
      for (const ProbeRecord& p : s.probes) {
        const double dx = p.position[0] - (8 * x + 4), dy = p.position[1] - (8 * y + 4);
        const double wi = std::exp(-(dx * dx + dy * dy) / (2 * 64.0));
        const int gx = std::clamp(int(p.position[0] / 8), 0, 7), gy = std::clamp(int(p.position[1] / 8), 0, 7);
        w += wi;
        // Relative to open flat ground (runtime/occlusion.h), at most 1.
        v += wi * std::min(1.0, (p.sky_vis[0] + p.sky_vis[1] + p.sky_vis[2]) / (3 * 65535.0 * runtime::kOpenGroundSkyVisibility));
        h += wi * std::max(0.0, double(p.position[2]) - s.groundHeight(gx, gy));
      }
      EXPECT_NEAR(t.sky_visibility[y * 8 + x], std::lround(v / w * 255), kUnorm8Tolerance);
      EXPECT_NEAR(t.occluder_height[y * 8 + x], std::lround(std::min(1.0, h / w / 64.0) * 255), kUnorm8Tolerance);
    }
}

TEST(BuildOcclusionTile, ReadsOpenSkyForASectorWithoutProbes) {
  const Sector s = testing::makeSector({0, 0}, 0, 0, 1);
  const OcclusionTile t = buildOcclusionTile(s);
  for (int i = 0; i < 64; ++i) {
    EXPECT_EQ(t.sky_visibility[i], 255);
    EXPECT_EQ(t.occluder_height[i], 0);
  }
}

TEST(BuildOcclusionTile, FarFromEveryProbeTakesTheNearestProbe) {
  Sector s = testing::makeSector({0, 0}, 1, 0, 3);
  s.probes[0].position[0] = 2.f;
  s.probes[0].position[1] = 2.f;
  s.probes[0].sky_vis[0] = s.probes[0].sky_vis[1] = s.probes[0].sky_vis[2] = 65535 / 2;
  const OcclusionTile t = buildOcclusionTile(s);
  EXPECT_NEAR(t.visibility(7, 7), 0.5f / runtime::kOpenGroundSkyVisibility, 1.f / 255);
}

}  // namespace
}  // namespace drtv::streamer
