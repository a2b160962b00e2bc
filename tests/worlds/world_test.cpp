// Tests of the World's own functions: gradients, the sun's path, the sky, effects, bounds.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "drtv/worlds/summary.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {
namespace {

// Float interpolation of values of order 1: a few ulps of rounding.
constexpr float kColorTolerance = 1e-5f;
// Double trigonometry of unit vectors.
constexpr double kDirectionTolerance = 1e-9;

Gradient twoKeys() {
  Gradient g;
  g.keys = {{6.f, glm::vec3(1.f)}, {18.f, glm::vec3(3.f)}};
  return g;
}

TEST(Gradient, InterpolatesBetweenKeys) {
  EXPECT_NEAR(twoKeys().at(12.0).x, 2.f, kColorTolerance);
  EXPECT_NEAR(twoKeys().at(9.0).y, 1.5f, kColorTolerance);
}

TEST(Gradient, WrapsAcrossMidnight) {
  // From 18 h (3) to 6 h next day (1): 12 h span, midnight is halfway.
  EXPECT_NEAR(twoKeys().at(0.0).x, 2.f, kColorTolerance);
  EXPECT_NEAR(twoKeys().at(24.0).x, 2.f, kColorTolerance);
  EXPECT_NEAR(twoKeys().at(21.0).x, 2.5f, kColorTolerance);
  EXPECT_NEAR(twoKeys().at(3.0).x, 1.5f, kColorTolerance);
  EXPECT_NEAR(twoKeys().at(-3.0).x, 2.5f, kColorTolerance);  // -3 h is 21 h
  EXPECT_NEAR(twoKeys().at(36.0).x, 2.f, kColorTolerance);   // 36 h is noon
}

TEST(Gradient, WithOneKeyIsConstant) {
  Gradient g;
  g.keys = {{10.f, glm::vec3(0.25f)}};
  EXPECT_EQ(g.at(3.0), glm::vec3(0.25f));
  EXPECT_EQ(g.at(23.9), glm::vec3(0.25f));
}

TEST(Sky, SunAtNoonPointsUpAndDueSouthOrNorth) {
  const Sky sky = Sky::tropicalDefault();
  const glm::dvec3 d = sky.sunDirection(12.0);
  // Reference: the noon elevation is 90 deg - |latitude - declination|.
  const double expected_elev = std::numbers::pi / 2 - std::abs(sky.latitude_rad - sky.declination_rad);
  EXPECT_NEAR(std::asin(d.z), expected_elev, kDirectionTolerance);
  EXPECT_NEAR(d.x, 0.0, kDirectionTolerance);
  EXPECT_GT(d.z, 0.9);
}

TEST(Sky, SunIsInTheEastInTheMorningAndWestInTheAfternoon) {
  const Sky sky = Sky::tropicalDefault();
  const glm::dvec3 morning = sky.sunDirection(8.0), evening = sky.sunDirection(16.0);
  EXPECT_GT(morning.x, 0.5);
  EXPECT_GT(morning.z, 0.0);
  EXPECT_LT(evening.x, -0.5);
  EXPECT_NEAR(glm::length(morning), 1.0, kDirectionTolerance);
  EXPECT_LT(sky.sunDirection(0.0).z, 0.0);  // below the horizon at midnight
}

TEST(Sky, SunElevationMatchesTheSolarFormula) {
  const Sky sky = Sky::tropicalDefault();
  for (double hour = 0; hour < 24; hour += 1.5) {
    const double h = (hour - 12) * std::numbers::pi / 12;
    const double elev = std::asin(std::sin(sky.latitude_rad) * std::sin(sky.declination_rad) +
                                  std::cos(sky.latitude_rad) * std::cos(sky.declination_rad) * std::cos(h));
    EXPECT_NEAR(std::asin(sky.sunDirection(hour).z), elev, kDirectionTolerance) << hour;
  }
}

TEST(Sky, NorthRotationTurnsTheSunPath) {
  Sky sky = Sky::tropicalDefault();
  const glm::dvec3 before = sky.sunDirection(8.0);
  sky.north_rad = std::numbers::pi / 2;  // north is now -X, east is +Y
  const glm::dvec3 after = sky.sunDirection(8.0);
  EXPECT_NEAR(after.y, before.x, kDirectionTolerance);
  EXPECT_NEAR(after.x, -before.y, kDirectionTolerance);
  EXPECT_NEAR(after.z, before.z, kDirectionTolerance);
}

TEST(Sky, TropicalDefaultIsBrightAtNoonOrangeAtDuskDarkAtNight) {
  const Sky sky = Sky::tropicalDefault();
  const glm::vec3 noon = sky.sun_irradiance.at(12.0);
  EXPECT_NEAR(noon.r, 3.0f, kColorTolerance);
  EXPECT_NEAR(noon.g, 2.9f, kColorTolerance);
  EXPECT_NEAR(noon.b, 2.6f, kColorTolerance);
  const glm::vec3 dusk = sky.sun_irradiance.at(18.0);
  EXPECT_GT(dusk.r, 2 * dusk.b);  // orange
  EXPECT_EQ(sky.sun_irradiance.at(0.0), glm::vec3(0.f));
  EXPECT_EQ(sky.sun_irradiance.at(22.0), glm::vec3(0.f));
  const glm::vec3 zenith = sky.sky_zenith.at(12.0);
  EXPECT_GT(zenith.b, zenith.r);
  EXPECT_LT(sky.sky_zenith.at(0.0).b, 0.02f);
  const glm::vec3 horizon_dusk = sky.sky_horizon.at(18.0);
  EXPECT_GT(horizon_dusk.r, horizon_dusk.b);
}

TEST(Sky, RadianceBlendsHorizonToZenith) {
  const Sky sky = Sky::tropicalDefault();
  EXPECT_EQ(sky.skyRadiance({0, 0, 1}, 12.0), sky.sky_zenith.at(12.0));
  EXPECT_EQ(sky.skyRadiance({1, 0, 0}, 12.0), sky.sky_horizon.at(12.0));
  EXPECT_EQ(sky.skyRadiance({0, 0, -1}, 12.0), glm::vec3(0.f));  // ground_radiance_scale 0
  const glm::vec3 mid = sky.skyRadiance(glm::normalize(glm::dvec3(1, 0, 0.25 / std::sqrt(1 - 0.0625))), 12.0);
  const glm::vec3 expected = glm::mix(sky.sky_horizon.at(12.0), sky.sky_zenith.at(12.0), 0.5f);  // sqrt(0.25)
  EXPECT_NEAR(mid.b, expected.b, 1e-4f);  // the direction's z is 0.25 only to double rounding
}

World twoBoxes() {
  World w;
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2};
  w.meshes.push_back(m);
  w.instances.push_back(Instance{0, glm::dmat4(1.0), InstanceClass::kStatic, "a"});
  w.instances.push_back(Instance{0, glm::translate(glm::dmat4(1.0), glm::dvec3(100, 0, 5)), InstanceClass::kVegetation, "b"});
  return w;
}

TEST(World, CountsTrianglesPerInstanceAndClasses) {
  const World w = twoBoxes();
  EXPECT_EQ(w.triangleCount(), 2u);
  const auto by_class = w.instancesByClass();
  EXPECT_EQ(by_class[size_t(InstanceClass::kStatic)], 1u);
  EXPECT_EQ(by_class[size_t(InstanceClass::kVegetation)], 1u);
  EXPECT_EQ(by_class[size_t(InstanceClass::kDynamic)], 0u);
}

TEST(World, BoundsCoverTransformedInstances) {
  const Bounds b = twoBoxes().bounds();
  EXPECT_EQ(b.min, glm::dvec3(0, 0, 0));
  EXPECT_EQ(b.max, glm::dvec3(101, 1, 5));
  EXPECT_TRUE(World{}.bounds().empty());
}

TEST(World, AnInstanceOfAMissingMeshIsAnErrorNamingItWhateverItsClass) {
  EXPECT_TRUE(twoBoxes().validate());
  for (InstanceClass cls : {InstanceClass::kStatic, InstanceClass::kVegetation, InstanceClass::kDynamic}) {
    World w = twoBoxes();
    w.instances.push_back(Instance{3, glm::dmat4(1.0), cls, "stray"});
    const auto ok = w.validate();
    ASSERT_FALSE(ok);
    EXPECT_EQ(ok.error().message, "instance 2 'stray': mesh index 3 out of range (1 meshes)");
  }
}

TEST(WorldDeathTest, BoundsOfAWorldThatValidateRefusesIsABug) {
  World w = twoBoxes();
  w.instances.push_back(Instance{3, glm::dmat4(1.0), InstanceClass::kDynamic, "stray"});
  EXPECT_DEATH((void)w.bounds(), "inst.mesh");
  EXPECT_DEATH((void)w.triangleCount(), "inst.mesh");
}

TEST(DefaultEffects, WithoutLightsOmitsLocalLights) {
  World w;
  const uint32_t e = defaultEffects(w);
  EXPECT_FALSE(e & kEffectLocalLights);
  EXPECT_FALSE(e & kEffectInteriors);
  EXPECT_FALSE(e & kEffectVolumeBlur);
  EXPECT_TRUE(e & kEffectSunBounce);
  EXPECT_TRUE(e & kEffectSkyBounce);
  EXPECT_TRUE(e & kEffectDirectSky);
  EXPECT_TRUE(e & kEffectDistantOcclusion);
}

TEST(DefaultEffects, FollowLightsInteriorsAndVegetation) {
  World w = twoBoxes();
  w.lights.push_back(PointLight{});
  w.interiors.push_back(InteriorVolume{});
  const uint32_t e = defaultEffects(w);
  EXPECT_TRUE(e & kEffectLocalLights);
  EXPECT_TRUE(e & kEffectInteriors);
  EXPECT_TRUE(e & kEffectVolumeBlur);
}

TEST(WorldSummary, CountsSectorsTouchedByTheBounds) {
  const WorldSummary s = summarize(twoBoxes());
  // x from 0 to 101 m: sectors 0 and 1; y from 0 to 1 m: sector 0.
  EXPECT_EQ(s.sector_min_x, 0);
  EXPECT_EQ(s.sector_max_x, 1);
  EXPECT_EQ(s.sector_min_y, 0);
  EXPECT_EQ(s.sector_max_y, 0);
  EXPECT_EQ(s.sectors, 2u);
  EXPECT_EQ(s.triangles, 2u);
  EXPECT_NE(toString(s).find("triangles: 2"), std::string::npos);
}

TEST(WorldSummary, NegativeCoordinatesFloorToNegativeSectors) {
  World w = twoBoxes();
  w.instances[0].transform = glm::translate(glm::dmat4(1.0), glm::dvec3(-1, -65, 0));
  const WorldSummary s = summarize(w);
  EXPECT_EQ(s.sector_min_x, -1);
  EXPECT_EQ(s.sector_min_y, -2);
}

}  // namespace
}  // namespace drtv::worlds

namespace drtv::worlds {
namespace {

// The reports' notes (summary.h collapseNotes): a form past kNotesOfAForm notes is one line with
// its count; other forms stay whole and in place; a run just one over the limit is not folded.
TEST(Notes, ManyNotesOfOneFormCollapseToAFewAndACount) {
  std::vector<std::string> notes;
  notes.push_back("warning: a.glb: required extension KHR_x is not supported; loaded without it");
  for (int i = 0; i < 1945; ++i)
    notes.push_back("material: a.glb: material " + std::to_string(i) + " 'Mat_" + std::to_string(i * 7) + "': metallic 0." +
                    std::to_string(i % 10) + ": diffuse albedo = base colour x 0.5");
  notes.push_back("skipped: a.glb: node 3 does not exist");
  for (int i = 0; i < 4; ++i) notes.push_back("dropped: a.glb mesh " + std::to_string(i) + ": 2 zero-area triangles");
  const std::vector<std::string> out = collapseNotes(notes);
  ASSERT_EQ(out.size(), 1u + 3u + 1u + 1u + 4u);
  EXPECT_EQ(out[0], notes[0]);
  EXPECT_EQ(out[1], notes[1]);
  EXPECT_EQ(out[3], notes[3]);
  EXPECT_EQ(out[4], "... and 1,942 more like these: material: a.glb: material # '\u2026': metallic #: diffuse albedo = base colour x #");
  EXPECT_EQ(out[5], "skipped: a.glb: node 3 does not exist");
  EXPECT_EQ(out[9], notes.back()) << "four of a form: one more than the limit is shown, not folded";
  EXPECT_TRUE(collapseNotes({}).empty());
}

}  // namespace
}  // namespace drtv::worlds

