// The reference path tracer against closed-form answers (reference.h).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "drtv/reference/reference.h"
#include "drtv/formats/sh.h"
#include "test_scenes.h"

namespace drtv::baker {
using namespace raytrace;
using namespace reference;
namespace {

using testing::kPi;
using testing::kUpBasisSkyFraction;

// Five standard errors: a correct estimator fails such a check about once in 1.7 million draws
// (normal tails); the seeds are fixed, so a pass is reproducible.
constexpr double kSigmas = 5.0;
// Estimates with no variance (every path contributes the same value) still carry float rounding
// of a few ulps per bounce.
constexpr double kFloatRel = 1e-4;
// A 20 km plane seen from 1 m misses a cosine-weighted solid-angle fraction of h^2 / (h^2 + R^2)
// = 1e-8 of the hemisphere: far below any tolerance here.
constexpr double kPlaneSizeM = 20000.0;

void expectWithin(const Estimate& e, const glm::dvec3& expected, const char* what, double extra_abs = 0.0) {
  for (int c = 0; c < 3; ++c) {
    const double tol = kSigmas * e.std_error[c] + kFloatRel * std::abs(expected[c]) + extra_abs + 1e-7;
    EXPECT_NEAR(e.mean[c], expected[c], tol) << what << " channel " << c << " (std error " << e.std_error[c] << ")";
  }
}

ReferenceScene buildScene(const worlds::World& w) {
  auto scene = ReferenceScene::build(w, "test");
  EXPECT_TRUE(scene.has_value()) << (scene ? "" : scene.error().message);
  return std::move(*scene);
}

TEST(ReferenceOverAPlaneUnderAUniformSky, SeesTheSkyOverTheCosineWeightedFractionAboveThePlane) {
  const glm::vec3 rho(0.5f, 0.25f, 0.75f);
  const ReferenceScene scene = buildScene(testing::planeWorld(kPlaneSizeM, rho));
  ReferenceLighting light;
  light.sky = testing::uniformSky(1.f, 1.f);
  ReferenceSettings s;
  s.samples = 4096;
  for (int b = 0; b < 3; ++b) {
    const ReferenceIrradiance r = referenceIrradiance(scene, light, {glm::dvec3(3, 4, 1), sh::kBasis[b], 7}, s);
    expectWithin(r.parts[kRefDirectSky], glm::dvec3(kPi * kUpBasisSkyFraction), "direct sky");
    // What the plane hides bounces once: rho pi L times the hidden fraction.
    expectWithin(r.parts[kRefSkyBounce], glm::dvec3(rho) * kPi * (1.0 - kUpBasisSkyFraction), "sky bounce");
    expectWithin(r.parts[kRefSunBounce], glm::dvec3(0.0), "sun bounce");
  }
}

TEST(ReferenceOverAPlaneUnderAUniformSky, GivesTheDownBasisTheBounceRhoPiL) {
  const glm::vec3 rho(0.5f, 0.25f, 0.75f);
  const float L = 2.f;
  const ReferenceScene scene = buildScene(testing::planeWorld(kPlaneSizeM, rho));
  ReferenceLighting light;
  light.sky = testing::uniformSky(L, 0.f);
  ReferenceSettings s;
  s.samples = 256;
  const ReferenceIrradiance r = referenceIrradiance(scene, light, {glm::dvec3(0, 0, 1), glm::vec3(0, 0, -1), 1}, s);
  expectWithin(r.parts[kRefSkyBounce], glm::dvec3(rho) * kPi * double(L), "sky bounce");
  expectWithin(r.parts[kRefDirectSky], glm::dvec3(0.0), "direct sky");
  expectWithin(r.ambient, glm::dvec3(rho) * kPi * double(L), "ambient");
}

TEST(ReferenceOverAPlaneUnderTheSun, GivesTheExactDeltaBounceAndDirectSun) {
  const glm::vec3 rho(0.6f);
  const float E = 3.f;
  const ReferenceScene scene = buildScene(testing::planeWorld(kPlaneSizeM, rho));
  ReferenceLighting light;
  light.sky = testing::sunOnlySky(E, 60.0);
  light.hour = 12.0;
  const ReferenceSun sun = referenceSun(light.sky, light.hour);
  ASSERT_NEAR(sun.direction.z, std::sin(60.0 * kPi / 180.0), 1e-5);
  const double plane_E = E * sun.direction.z;  // irradiance on the plane
  ReferenceSettings s;
  s.samples = 2048;
  const ReferenceIrradiance down = referenceIrradiance(scene, light, {glm::dvec3(0, 0, 1), glm::vec3(0, 0, -1), 2}, s);
  expectWithin(down.parts[kRefSunBounce], glm::dvec3(rho.x * plane_E), "sun bounce, down");
  expectWithin(down.parts[kRefDirectSun], glm::dvec3(0.0), "direct sun, down");
  const ReferenceIrradiance up = referenceIrradiance(scene, light, {glm::dvec3(0, 0, 1), glm::vec3(0, 0, 1), 3}, s);
  expectWithin(up.parts[kRefDirectSun], glm::dvec3(plane_E), "direct sun, up");
  expectWithin(up.parts[kRefSunBounce], glm::dvec3(0.0), "sun bounce, up");
  const ReferenceIrradiance b0 = referenceIrradiance(scene, light, {glm::dvec3(0, 0, 1), sh::kBasis[0], 4}, s);
  expectWithin(b0.parts[kRefSunBounce], glm::dvec3(rho.x * plane_E * (1.0 - kUpBasisSkyFraction)), "sun bounce, B0");
}

TEST(ReferenceSun, IsSetWhenAtOrBelowTheHorizon) {
  Sky sky = testing::sunOnlySky(3.f, 60.0);
  EXPECT_GT(referenceSun(sky, 12.0).irradiance.x, 0.f);
  EXPECT_EQ(referenceSun(sky, 0.0).irradiance, glm::vec3(0.f));  // midnight: below the horizon
}

// A closed sphere of radius R, albedo rho, a point light I at its centre: every wall point gets
// E0 = I / R^2 directly and, the wall radiance being uniform, pi L from the rest of the wall, so
// E = E0 + rho E  =>  the bounced part anywhere inside is rho E0 / (1 - rho): every bounce counts.
worlds::World closedSphere(double radius_m, const glm::vec3& rho, int segments) {
  worlds::World w;
  w.name = "sphere";
  worlds::Mesh m;
  m.name = "inside of a sphere";
  m.albedo = rho;
  const int rings = segments / 2;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const double th = kPi * i / rings, ph = 2 * kPi * j / segments;
      m.positions.push_back(glm::vec3(glm::dvec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)) * radius_m));
    }
  auto at = [&](int i, int j) { return uint32_t(i * segments + (j % segments)); };
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      // Wound clockwise seen from outside: the front faces look inward.
      if (i > 0) m.indices.insert(m.indices.end(), {at(i, j), at(i, j + 1), at(i + 1, j)});
      if (i + 1 < rings) m.indices.insert(m.indices.end(), {at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)});
    }
  w.meshes.push_back(m);
  worlds::Instance inst;
  inst.cls = worlds::InstanceClass::kStatic;
  w.instances.push_back(inst);
  return w;
}

TEST(ReferenceInAClosedSphere, SumsEveryBounceOfAPointLight) {
  // A 96-segment sphere's facets lie within R (1 - cos(pi / 96)) = 0.05% of R: the tolerance.
  constexpr double kFacetRel = 0.01;
  const double R = 5.0;
  const float I = 10.f;
  for (float rho : {0.3f, 0.8f}) {
    const ReferenceScene scene = buildScene(closedSphere(R, glm::vec3(rho), 96));
    ReferenceLighting light;
    light.sky = testing::uniformSky(0.f, 0.f);
    light.lights.push_back(PointLight{"centre", glm::dvec3(0.0), glm::vec3(I), 10.f});
    ReferenceSettings s;
    s.samples = 2048;
    const ReferenceIrradiance r = referenceIrradiance(scene, light, {glm::dvec3(0.3, -0.2, 0.5), glm::vec3(0.6f, 0.f, 0.8f), 9}, s);
    const double e0 = I / (R * R), expected = rho * e0 / (1.0 - rho);
    expectWithin(r.parts[kRefLocalLights], glm::dvec3(expected), "local lights", kFacetRel * expected);
    expectWithin(r.parts[kRefDirectSky], glm::dvec3(0.0), "direct sky");
  }
}

// With more lights than a path traces one by one (a town's lamps), the lights past the few that
// matter are sampled (reference.cpp, kExactLightsUpTo): still the physics. In a closed sphere the
// light a point on the wall receives after the first reflection is rho Phi / (4 pi R^2) wherever
// the lights stand (every wall element sees every other with the form factor dA / (4 pi R^2)), and
// each later reflection multiplies it by rho: rho sum(I) / (R^2 (1 - rho)) for lights of intensity
// I anywhere inside. 64 lights of unequal intensities scattered off-centre, read at the wall.
TEST(ReferenceInAClosedSphere, SumsEveryBounceOfSixtyFourLightsItSamples) {
  constexpr double kFacetRel = 0.01;
  const double R = 5.0, rho = 0.5;
  const ReferenceScene scene = buildScene(closedSphere(R, glm::vec3(float(rho)), 96));
  ReferenceLighting light;
  light.sky = testing::uniformSky(0.f, 0.f);
  double sum_i = 0.0;
  for (int k = 0; k < 64; ++k) {
    const double a = 2.399963 * k, z = -0.9 + 1.8 * (k + 0.5) / 64.0, r = 3.0 * std::sqrt(1.0 - z * z);
    const float intensity = 0.25f + 0.5f * float(k % 7);
    light.lights.push_back(PointLight{"lamp " + std::to_string(k), glm::dvec3(r * std::cos(a), r * std::sin(a), 3.0 * z),
                                      glm::vec3(intensity), 10.f});
    sum_i += intensity;
  }
  ReferenceSettings s;
  s.samples = 2048;
  const glm::dvec3 d = glm::normalize(glm::dvec3(0.3, -0.5, 0.2));
  const ReferenceIrradiance r = referenceIrradiance(scene, light, {d * (0.999 * R), glm::vec3(-d), 11}, s);
  const double expected = rho * sum_i / (R * R * (1.0 - rho));
  expectWithin(r.parts[kRefLocalLights], glm::dvec3(expected), "local lights", kFacetRel * expected);
  // Sampled, not traced to every light: fewer rays a path than 64 (tracing all, every vertex of a
  // path would cast 64 shadow rays).
  EXPECT_LT(double(r.rays) / s.samples, 64.0) << "rays per path";
}

TEST(ReferenceIrradiance, IsTheSameBitsOnOneThreadAndOnMany) {
  const ReferenceScene scene = buildScene(testing::planeWorld(100.0, glm::vec3(0.5f)));
  ReferenceLighting light;
  ReferenceSettings s;
  s.samples = 64;
  std::vector<ReferenceQuery> q;
  for (int i = 0; i < 40; ++i) q.push_back({glm::dvec3(i - 20, 0.5 * i, 1.0), sh::kBasis[i % 4], uint64_t(i)});
  const auto a = referenceIrradiance(scene, light, q, s, 1);
  const auto b = referenceIrradiance(scene, light, q, s, 0);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].ambient.mean, b[i].ambient.mean) << i;
    EXPECT_EQ(a[i].ambient.std_error, b[i].ambient.std_error) << i;
    EXPECT_EQ(a[i].rays, b[i].rays) << i;
  }
  // And a single query is the batch's answer for it.
  EXPECT_EQ(referenceIrradiance(scene, light, q[7], s).ambient.mean, a[7].ambient.mean);
}

TEST(ReferenceIrradiance, HasAStandardErrorThatHalvesWithFourTimesTheSamples) {
  // The ratio of two standard-error estimates from N and 4N paths is itself noisy (its relative
  // spread is about 1/sqrt(2N) ~ 3% at N = 512); 20% leaves room for that.
  constexpr double kRatioTolerance = 0.2;
  const ReferenceScene scene = buildScene(testing::planeWorld(kPlaneSizeM, glm::vec3(0.5f)));
  ReferenceLighting light;
  light.sky = testing::uniformSky(1.f, 0.f);
  ReferenceSettings s;
  s.samples = 512;
  const ReferenceQuery q{glm::dvec3(0, 0, 1), sh::kBasis[1], 11};
  const double e1 = referenceIrradiance(scene, light, q, s).ambient.std_error.x;
  s.samples = 2048;
  const double e4 = referenceIrradiance(scene, light, q, s).ambient.std_error.x;
  ASSERT_GT(e1, 0.0);
  EXPECT_NEAR(e4 / e1, 0.5, kRatioTolerance * 0.5);
}

TEST(ReferenceScene, KeepsItsLocalFrameNearTheGeometryFarFromTheOrigin) {
  const glm::dvec3 far(100032.0, -100032.0, 0.0);  // 100 km out, a whole number of sectors
  const ReferenceScene a = buildScene(testing::planeWorld(200.0, glm::vec3(0.5f)));
  const ReferenceScene b = buildScene(testing::planeWorld(200.0, glm::vec3(0.5f), far));
  EXPECT_EQ(b.origin() - a.origin(), far);
  ReferenceLighting light;
  ReferenceSettings s;
  s.samples = 256;
  const ReferenceIrradiance ra = referenceIrradiance(a, light, {glm::dvec3(3, 5, 1.5), glm::vec3(0, 0.6f, 0.8f), 5}, s);
  const ReferenceIrradiance rb = referenceIrradiance(b, light, {glm::dvec3(3, 5, 1.5) + far, glm::vec3(0, 0.6f, 0.8f), 5}, s);
  EXPECT_EQ(ra.ambient.mean, rb.ambient.mean);
}

}  // namespace
}  // namespace drtv::baker
