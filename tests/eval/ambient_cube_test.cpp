// The ambient-cube technique (eval/techniques/ambient_cube) through its whole pipeline — the drtv
// bake's placement, the cube's transfer bake, relight, the 18-byte volume, ambient() — against
// the closed-form answers over a grey plane (albedo 0.5) 2 m above it (issue 13):
//   uniform sky L = 1:   up pi, sideways 3 pi / 4, down pi / 2 (the ground's radiance rho L)
//   sun of irradiance E at elevation e, black sky:
//                        down rho E sin e (the ground bounce), sideways rho E sin e / 2, up 0.
// The same cases and tolerances as tests/reference/plane_physics_test.cpp holds sh-l1 to.
#include <gtest/gtest.h>

#include <cmath>

#include "../reference/test_scenes.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/load.h"

namespace drtv {
namespace {

using testing::kPi;

constexpr double kPlaneSizeM = 20000.0;
constexpr float kRho = 0.5f;
// 3 %: each axis colour of the cube is an unbiased estimate of that axis' irradiance (the sky
// and the ground are uniform hemispheres; a plane has one bounce, so the bounce count does not
// enter), and an axis normal reads its own face alone (weight n_a^2 = 1). What is left is the
// bake's Monte-Carlo noise (4 x 256 rays per probe, mixture-weighted: ~1 %) and the 8-bit texels
// (1/255 of an HDR scale of 1.25 x the brightest colour: 0.5 % of pi).
constexpr double kUniformSkyRel = 0.03;
// The issue's: 10 % for the sun's ground bounce (the exact first bounce at the sun path's
// samples, interpolated between the two nearest the sun), and the up normal below 0.01 E.
constexpr double kSunBounceRel = 0.10;
constexpr double kUpNormalAbs = 0.01;

struct Ambient {
  double up, side, down;
};

// The ambient (channel R) 2 m above sector (0, 0)'s centre at noon.
Ambient cubeOverPlane(const Sky& sky) {
  worlds::World world = testing::planeWorld(kPlaneSizeM, glm::vec3(kRho));
  world.sky = sky;
  auto t = eval::makeTechnique("ambient-cube", {{"rays_per_basis", "256"}});
  EXPECT_TRUE(t.has_value()) << (t ? "" : t.error().message);
  if (!t) return {};
  eval::PrepareInput in{world, "plane", raytrace::SectorRange{0, 0, 0, 0}};
  in.seed = 1;
  auto p = (*t)->prepare(in);
  EXPECT_TRUE(p.has_value()) << (p ? "" : p.error().message);
  EXPECT_TRUE((*t)->setLighting(12.0, {}).has_value());
  const glm::dvec3 at(32.0, 32.0, 2.0);
  EXPECT_TRUE((*t)->update(at).has_value());
  auto e = [&](glm::vec3 n) { return double((*t)->ambient(at, n).r); };
  return {e({0, 0, 1}), e({1, 0, 0}), e({0, 0, -1})};
}

double rel(double got, double want) { return (got - want) / want; }

TEST(AmbientCube, MatchesAUniformSkyOverAPlaneWithin3Percent) {
  const Ambient a = cubeOverPlane(testing::uniformSky(1.f, 1.f));
  RecordProperty("up", std::to_string(a.up));
  RecordProperty("side", std::to_string(a.side));
  RecordProperty("down", std::to_string(a.down));
  std::printf("[ cube sky ] up %.4f (%+.1f %%) side %.4f (%+.1f %%) down %.4f (%+.1f %%)\n", a.up, 100 * rel(a.up, kPi), a.side,
              100 * rel(a.side, 0.75 * kPi), a.down, 100 * rel(a.down, 0.5 * kPi));
  EXPECT_NEAR(rel(a.up, kPi), 0.0, kUniformSkyRel) << a.up;
  EXPECT_NEAR(rel(a.side, 0.75 * kPi), 0.0, kUniformSkyRel) << a.side;
  EXPECT_NEAR(rel(a.down, 0.5 * kPi), 0.0, kUniformSkyRel) << a.down;
}

TEST(AmbientCube, SunBounceOverAPlaneIsWithin10PercentAndNothingComesFromAbove) {
  for (double elevation : {30.0, 60.0, 90.0}) {
    const Ambient a = cubeOverPlane(testing::sunOnlySky(1.f, elevation));
    const double s = std::sin(elevation * kPi / 180.0);
    std::printf("[ cube sun ] %2.0f deg: down %.4f (exact %.4f, %+.1f %%) side %.4f (%+.1f %%) up %.4f\n", elevation, a.down, kRho * s,
                100 * rel(a.down, kRho * s), a.side, 100 * rel(a.side, 0.5 * kRho * s), a.up);
    RecordProperty("down_" + std::to_string(int(elevation)), std::to_string(a.down));
    RecordProperty("up_" + std::to_string(int(elevation)), std::to_string(a.up));
    EXPECT_NEAR(rel(a.down, kRho * s), 0.0, kSunBounceRel) << elevation << " deg: " << a.down << " vs " << kRho * s;
    EXPECT_NEAR(rel(a.side, 0.5 * kRho * s), 0.0, kSunBounceRel) << elevation << " deg sideways: " << a.side;
    EXPECT_LT(std::fabs(a.up), kUpNormalAbs) << elevation << " deg up: " << a.up;
  }
}

// The volume after the camera has wandered (slabs filled as they entered, on both sides of every
// axis, a relight in between) holds what a volume relit and filled whole at the same camera
// holds: the scroll's slabs, the probe look-ups it keeps per texel and the blur's borders are
// the full fill's, texel for texel. On the island (relief, buildings, vegetation: neighbouring
// texels differ, and the volume blur is on), read back through ambient() over the whole window
// after every move.
TEST(AmbientCube, AScrolledVolumeEqualsOneFilledWholeAtTheSameCamera) {
  auto world = worlds::loadWorld(DRTV_SOURCE_DIR "/worlds/island.json");
  ASSERT_TRUE(world.has_value()) << (world ? "" : world.error().message);
  auto make = [&] {
    auto t = eval::makeTechnique("ambient-cube", {{"quality", "draft"}});
    EXPECT_TRUE(t.has_value());
    eval::PrepareInput in{*world, "island", raytrace::SectorRange{0, 1, 0, 1}};
    in.threads = 2;
    EXPECT_TRUE((*t)->prepare(in).has_value());
    return std::move(*t);
  };
  auto wandered = make(), whole = make();
  struct Step {
    glm::dvec3 camera;
    double hour;  // a new hour relights
  };
  // The block spans x, y in [0, 128] m and the window +-96 m: cameras near the block's edges put
  // the entering slabs (of a few texels) inside it, where texels 192 m apart (one period) differ.
  const Step path[] = {{{10.0, 10.0, 10.0}, 9.0},   {{20.0, 22.0, 2.0}, 9.0},   {{118.0, 118.0, 14.0}, 9.0},
                       {{108.0, 106.0, 5.0}, 9.0}, {{12.0, 110.0, 8.0}, 15.0}, {{24.0, 100.0, 16.0}, 15.0}};
  double hour = -1.0;
  for (const Step& step : path) {
    if (step.hour != hour) {
      ASSERT_TRUE(wandered->setLighting(step.hour, {}).has_value());
    }
    hour = step.hour;
    ASSERT_TRUE(wandered->update(step.camera).has_value());
    ASSERT_TRUE(whole->setLighting(step.hour, {}).has_value());
    ASSERT_TRUE(whole->update(step.camera).has_value());
    int differ = 0, lit = 0;
    for (double x = -93.0; x <= 93.0; x += 3.1)
      for (double y = -93.0; y <= 93.0; y += 3.7)
        for (double z = -31.0; z <= 31.0; z += 2.9)
          for (const glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(-1, 0, 0), glm::vec3(0.6f, -0.8f, 0.f), glm::vec3(0, 0, -1)}) {
            const glm::dvec3 p = step.camera + glm::dvec3(x, y, z);
            const glm::vec3 a = wandered->ambient(p, n), b = whole->ambient(p, n);
            differ += a != b;
            lit += a.r > 0.f;
          }
    EXPECT_EQ(differ, 0) << "camera " << step.camera.x << ", " << step.camera.y << ", " << step.camera.z;
    EXPECT_GT(lit, 0);
  }
}

// Parameters are checked at make time (technique.h): an unknown name or value is an error.
TEST(AmbientCube, RejectsUnknownParameters) {
  EXPECT_FALSE(eval::makeTechnique("ambient-cube", {{"representation", "sh-l1"}}).has_value());
  EXPECT_FALSE(eval::makeTechnique("ambient-cube", {{"sun_transfer", "maybe"}}).has_value());
  EXPECT_TRUE(eval::makeTechnique("ambient-cube", {{"sun_transfer", "off"}, {"part", "direct_sky"}}).has_value());
}

}  // namespace
}  // namespace drtv
