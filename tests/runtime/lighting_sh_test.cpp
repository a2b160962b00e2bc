// Time of day -> sun and sky SH: closed forms against numerical projection, windowing, fade.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include <vector>

#include "drtv/runtime/lighting_sh.h"

namespace drtv::runtime {
namespace {

// projectNumerically's midpoint rule on a 256 x 512 grid integrates sqrt(z) (unbounded slope at
// the horizon) to about 1e-4 of the total; 1e-3 of the largest coefficient leaves room for that.
constexpr float kQuadratureRelTol = 1e-3f;

TEST(SkySh, ClosedFormMatchesNumericalProjection) {
  struct Case {
    float zenith, horizon, ground;
  };
  for (const Case& k : {Case{0.2f, 0.5f, 0.f}, Case{1.f, 0.1f, 0.3f}, Case{0.f, 0.f, 0.f}, Case{0.7f, 0.7f, 1.f}, Case{0.01f, 2.f, 0.05f}}) {
    const sh::Sh4 closed = projectSkyGradient(k.zenith, k.horizon, k.ground);
    const sh::Sh4 numeric = sh::projectNumerically([&](const glm::vec3& w) {
      if (w.z < 0.f) return k.ground * k.horizon;
      return k.horizon + (k.zenith - k.horizon) * std::sqrt(std::min(w.z, 1.f));
    });
    const float scale = std::max(1e-6f, std::fabs(numeric[0]));
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(closed[i], numeric[i], kQuadratureRelTol * scale) << "coefficient " << i;
  }
}

TEST(SkySh, ClosedFormMatchesTheSkysOwnRadianceFunction) {
  const Sky sky = Sky::tropicalDefault();
  for (double hour : {6.5, 12.0, 17.9, 23.0}) {
    const SkyLighting s = evaluateSky(sky, hour);
    for (int c = 0; c < 3; ++c) {
      const sh::Sh4 numeric = sh::projectNumerically(
          [&](const glm::vec3& w) { return sky.skyRadiance(glm::dvec3(w), hour)[c]; });
      for (int i = 0; i < 4; ++i) EXPECT_NEAR(s.sky_sh[c][i], numeric[i], kQuadratureRelTol * std::fabs(numeric[0]));
    }
  }
}

TEST(SunSh, BandZeroCarriesTheSunsEnergyWhateverTheWindow) {
  const glm::vec3 dir = glm::normalize(glm::vec3(0.3f, -0.4f, 0.8f));
  for (float w : {kNoWindowBand1, kLanczosBand1, kHanningBand1}) {
    const sh::Sh4Rgb s = projectSun(dir, {2.f, 1.f, 0.5f}, w);
    EXPECT_FLOAT_EQ(s[0][0], 2.f * sh::kY0);
    EXPECT_FLOAT_EQ(s[2][0], 0.5f * sh::kY0);
    EXPECT_FLOAT_EQ(s[0][3], 2.f * sh::kY1 * dir.x * w);
  }
}

TEST(SunSh, HanningWindowNeverGivesNegativeBounceThroughAClampedCosineTransfer) {
  // A transfer that is a clamped cosine about m (a lit surface facing m): the sun term is
  // E (1/4 + w1/2 cos); Hanning keeps it >= 0 for every sun direction, the raw delta does not.
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  float worst_hanning = 1.f, worst_raw = 1.f;
  for (int i = 0; i < 2000; ++i) {
    const glm::vec3 d = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    const glm::vec3 m = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    worst_hanning = std::min(worst_hanning, glm::dot(projectSun(d, glm::vec3(1.f), kHanningBand1)[0], sh::cosineLobe(m)));
    worst_raw = std::min(worst_raw, glm::dot(projectSun(d, glm::vec3(1.f), kNoWindowBand1)[0], sh::cosineLobe(m)));
  }
  EXPECT_GE(worst_hanning, -1e-6f);
  EXPECT_LT(worst_raw, -0.2f);
}

TEST(SunSh, FadesOutSmoothlyBelowTheHorizon) {
  EXPECT_EQ(sunHorizonFade(-0.1), 0.f);
  EXPECT_EQ(sunHorizonFade(kSunFadeBottomRad), 0.f);
  EXPECT_EQ(sunHorizonFade(kSunFadeTopRad), 1.f);
  EXPECT_EQ(sunHorizonFade(1.0), 1.f);
  EXPECT_EQ(sunHorizonFade(std::nan("")), 0.f);
  float last = 0.f;
  for (int i = 0; i <= 100; ++i) {
    const float f = sunHorizonFade(kSunFadeBottomRad + (kSunFadeTopRad - kSunFadeBottomRad) * i / 100.0);
    EXPECT_GE(f, last);
    last = f;
  }
}

TEST(EvaluateSky, FollowsTheGradientsAndTheSunPath) {
  const Sky sky = Sky::tropicalDefault();
  const SkyLighting noon = evaluateSky(sky, 12.0);
  EXPECT_GT(noon.sun_direction.z, 0.9f);
  EXPECT_EQ(noon.sun_fade, 1.f);
  EXPECT_EQ(noon.sun_irradiance, sky.sun_irradiance.at(12.0));
  const SkyLighting midnight = evaluateSky(sky, 24.0 + 0.0);
  EXPECT_EQ(midnight.hour, 0.0);
  EXPECT_EQ(midnight.sun_fade, 0.f);
  EXPECT_EQ(midnight.sun_irradiance, glm::vec3(0.f));
  const SkyLighting wrapped = evaluateSky(sky, -12.0);
  EXPECT_EQ(wrapped.hour, 12.0);
}

TEST(EvaluateSky, SunStillInTheGradientAfterSunsetLightsNothing) {
  Sky sky = Sky::tropicalDefault();
  sky.sun_irradiance.keys = {{0.f, glm::vec3(5.f)}};  // an artist error: sun all night
  const SkyLighting s = evaluateSky(sky, 0.5);
  EXPECT_LT(s.sun_direction.z, 0.f);
  EXPECT_EQ(s.sun_sh[0], sh::Sh4(0.f));
}

TEST(LightingChange, IsZeroForTheSameLightingAndGrowsWithTime) {
  const Sky sky = Sky::tropicalDefault();
  const SkyLighting a = evaluateSky(sky, 10.0);
  EXPECT_EQ(lightingChange(a, a), 0.f);
  EXPECT_GT(lightingChange(a, evaluateSky(sky, 10.5)), lightingChange(a, evaluateSky(sky, 10.01)));
  EXPECT_LT(lightingChange(a, evaluateSky(sky, 10.0 + 1.0 / 3600.0)), 1.f / 512.f);  // one second
}

}  // namespace
// The sun transfer's interpolation along the baked path (lighting_sh.h, sunTransferWeights).
TEST(SunTransferWeights, AreOneOnASampleLinearByAngleBetweenAndNoneOffThePath) {
  // Five samples along a quarter great circle in the x-z plane, 22.5 deg apart.
  std::vector<glm::vec3> path;
  for (int k = 0; k < 5; ++k) {
    const float a = float(k) * 0.3926991f;
    path.push_back({std::cos(a), 0.f, std::sin(a)});
  }
  std::vector<float> w(path.size());
  sunTransferWeights(path, path[2], w);
  EXPECT_NEAR(w[2], 1.f, 1e-5f);
  EXPECT_NEAR(w[0] + w[1] + w[3] + w[4], 0.f, 1e-5f);
  // A quarter of the way from sample 1 to sample 2.
  const float a = 1.25f * 0.3926991f;
  sunTransferWeights(path, glm::vec3(std::cos(a), 0.f, std::sin(a)), w);
  EXPECT_NEAR(w[1], 0.75f, 1e-3f);
  EXPECT_NEAR(w[2], 0.25f, 1e-3f);
  // Off the path by a little: both weights shrink together; by a segment's length: nothing.
  const glm::vec3 off_a = glm::normalize(glm::vec3(std::cos(a), 0.1f, std::sin(a)));
  sunTransferWeights(path, off_a, w);
  EXPECT_GT(w[1] + w[2], 0.5f);
  EXPECT_LT(w[1] + w[2], 1.f);
  EXPECT_NEAR(w[1] / (w[1] + w[2]), 0.75f, 0.1f);
  sunTransferWeights(path, glm::vec3(0.f, 1.f, 0.f), w);
  for (float x : w) EXPECT_EQ(x, 0.f);
  // Not finite: nothing.
  sunTransferWeights(path, glm::vec3(NAN), w);
  for (float x : w) EXPECT_EQ(x, 0.f);
}

TEST(SunTransferWeights, CloseARingUnderAMidnightSun) {
  // Eight samples around the whole day at 10 deg elevation: the last and the first are neighbours.
  std::vector<glm::vec3> ring;
  for (int k = 0; k < 8; ++k) {
    const float a = float(k) * 0.7853982f;
    ring.push_back(glm::normalize(glm::vec3(std::cos(a), std::sin(a), 0.1763f)));
  }
  std::vector<float> w(ring.size());
  const float a = 7.5f * 0.7853982f;  // halfway from sample 7 back to sample 0
  sunTransferWeights(ring, glm::normalize(glm::vec3(std::cos(a), std::sin(a), 0.1763f)), w);
  EXPECT_NEAR(w[7], 0.5f, 1e-3f);
  EXPECT_NEAR(w[0], 0.5f, 1e-3f);
}

}  // namespace drtv::runtime
