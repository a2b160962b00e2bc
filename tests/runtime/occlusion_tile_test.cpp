// Occlusion tiles: a slow double-precision reference, the empty sector, the ground map, open ground.
#include <cmath>

#include <gtest/gtest.h>

#include "test_sectors.h"
#include "drtv/formats/quantize.h"
#include "drtv/runtime/occlusion.h"

namespace drtv::runtime {
namespace {

// unorm8 rounding plus float summation order: one step.
constexpr int kUnorm8Tolerance = 1;

TEST(OcclusionTile, MatchesAGaussianWeightedMeanComputedInDouble) {
  const Sector s = testing::makeSector({3, 4}, 70, 0, 7);
  const OcclusionTile t = makeOcclusionTile(s);
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
        v += wi * std::min(1.0, (p.sky_vis[0] + p.sky_vis[1] + p.sky_vis[2]) / (3 * 65535.0 * kOpenGroundSkyVisibility));
        h += wi * std::max(0.0, double(p.position[2]) - s.groundHeight(gx, gy));
      }
      EXPECT_NEAR(t.sky_visibility[y * 8 + x], std::lround(v / w * 255), kUnorm8Tolerance);
      EXPECT_NEAR(t.occluder_height[y * 8 + x], std::lround(std::min(1.0, h / w / 64.0) * 255), kUnorm8Tolerance);
      // The ground map is carried over exactly.
      EXPECT_FLOAT_EQ(t.groundM(x, y), s.groundHeight(x, y));
    }
}

TEST(OcclusionTile, WithoutAGroundMapTakesTheGroundFromTheProbesBases) {
  Sector s = testing::makeSector({3, 4}, 70, 0, 9);
  s.has_ground = false;
  const OcclusionTile t = makeOcclusionTile(s);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      double w = 0, b = 0;
      for (const ProbeRecord& p : s.probes) {
        const double dx = p.position[0] - (8 * x + 4), dy = p.position[1] - (8 * y + 4);
        const double wi = std::exp(-(dx * dx + dy * dy) / (2 * 64.0));
        w += wi;
        b += wi * (double(p.position[2]) - p.height_cm / 100.0);
      }
      // The tabulated Gaussian errs by at most 0.0012 per axis (occlusion.cpp), so each product
      // weight by dw <= 0.0025; the mean moves by at most dw * sum |b_i - mean| / (w - n dw). Plus
      // the 16-bit quantisation of the range.
      constexpr double kWeightError = 0.0025;
      const double mean = b / w;
      double spread = 0;
      for (const ProbeRecord& p : s.probes) spread += std::fabs(double(p.position[2]) - p.height_cm / 100.0 - mean);
      const double bound = kWeightError * spread / (w - double(s.probes.size()) * kWeightError) +
                           (t.ground_z_max_m - t.ground_z_min_m) / 65535.0 + 1e-4;
      ASSERT_GT(w, double(s.probes.size()) * kWeightError);
      EXPECT_NEAR(t.groundM(x, y), mean, bound) << x << " " << y;
    }
}

TEST(OcclusionTile, ReadsOpenGroundAsOpenSky) {
  // Probes over open flat ground see the sky through their upward bases with (1 + cos 54.74)/2
  // (the ground hides the rest); the distant sky SH is black below the horizon already, so the
  // tile must not darken it again.
  Sector s = testing::makeSector({0, 0}, 70, 0, 5);
  for (ProbeRecord& r : s.probes) r.sky_vis[0] = r.sky_vis[1] = r.sky_vis[2] = quantizeUnorm16(kOpenGroundSkyVisibility);
  const OcclusionTile t = makeOcclusionTile(s);
  for (uint8_t v : t.sky_visibility) EXPECT_EQ(v, 255);
  EXPECT_NEAR(kOpenGroundSkyVisibility, 0.5 * (1.0 + std::cos(std::acos(1.0 / std::sqrt(3.0)))), 1e-7);
}

TEST(OcclusionTile, ReadsOpenSkyForASectorWithoutProbes) {
  const Sector s = testing::makeSector({0, 0}, 0, 0, 1);
  const OcclusionTile t = makeOcclusionTile(s);
  for (int i = 0; i < 64; ++i) {
    EXPECT_EQ(t.sky_visibility[i], 255);
    EXPECT_EQ(t.occluder_height[i], 0);
  }
}

TEST(OcclusionTile, FarFromEveryProbeTakesTheNearestProbe) {
  Sector s = testing::makeSector({0, 0}, 1, 0, 3);
  s.probes[0].position[0] = 2.f;
  s.probes[0].position[1] = 2.f;
  s.probes[0].sky_vis[0] = s.probes[0].sky_vis[1] = s.probes[0].sky_vis[2] = 65535 / 2;
  const OcclusionTile t = makeOcclusionTile(s);
  EXPECT_NEAR(t.visibility(7, 7), 0.5f / kOpenGroundSkyVisibility, 1.f / 255);
}

TEST(OcclusionMap, DarkensTheGroundByTheTexelsVisibilityAndNothingAboveTheOccluders) {
  const Sector s = testing::makeSector({-2, 1}, 70, 0, 13);
  OcclusionMap map;
  map.add(makeOcclusionTile(s));
  const OcclusionTile t = *map.find(s.key);  // a copy: the map drops its own below
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      // At a texel centre the bilinear blend is that texel alone.
      const double wx = s.key.ix * kSectorSizeM + 8 * x + 4, wy = s.key.iy * kSectorSizeM + 8 * y + 4;
      const double ground = t.groundM(x, y), top = ground + std::max(t.heightM(x, y), kMinOccluderHeightM);
      EXPECT_NEAR(map.occlusion({wx, wy, ground}), t.visibility(x, y), 1e-5f);
      EXPECT_NEAR(map.occlusion({wx, wy, 0.5 * (ground + top)}), 0.5f * (1.f + t.visibility(x, y)), 1e-3f);
      EXPECT_EQ(map.occlusion({wx, wy, top + 0.01}), 1.f);
    }
  EXPECT_EQ(map.occlusion({1e5, 0.0, 0.0}), 1.f);  // no tile: open sky
  EXPECT_TRUE(map.remove(s.key));
  EXPECT_EQ(map.occlusion({s.key.ix * kSectorSizeM + 12.0, s.key.iy * kSectorSizeM + 12.0, t.groundM(1, 1)}), 1.f);
}

}  // namespace
}  // namespace drtv::runtime
