// Double-sided materials (docs/world-format.md, "Materials"): a surface from both sides, the same
// way in the path tracer and in the bake; a one-sided back face stays the inside of geometry.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "drtv/baker/bake.h"
#include "drtv/reference/reference.h"

namespace drtv::testing {
namespace {

constexpr double kPi = std::numbers::pi;

// A square ground of side `side` at z = 0 whose winding faces DOWN (as an upside-down authored
// floor would), placed at `centre`.
worlds::World groundWoundDown(double side, glm::dvec3 centre, bool double_sided, float albedo) {
  worlds::World w;
  w.name = double_sided ? "double-sided ground" : "one-sided ground";
  worlds::Mesh m;
  m.name = "ground";
  const float s = float(side / 2);
  m.positions = {{-s, -s, 0}, {s, -s, 0}, {s, s, 0}, {-s, s, 0}};
  m.indices = {0, 2, 1, 0, 3, 2};  // (b - a) x (c - a) points to -z
  m.albedo = glm::vec3(albedo);
  m.double_sided = double_sided;
  w.meshes = {m};
  w.instances = {{0, glm::translate(glm::dmat4(1.0), centre), worlds::InstanceClass::kTerrain, "ground"}};
  w.effects = worlds::defaultEffects(w);
  return w;
}

// A sky of radiance L everywhere above the horizon, nothing below, no sun.
Sky uniformSky(float radiance) {
  Sky s = Sky::tropicalDefault();
  s.sun_irradiance.keys = {{0.f, glm::vec3(0.f)}};
  s.sky_zenith.keys = {{0.f, glm::vec3(radiance)}};
  s.sky_horizon.keys = {{0.f, glm::vec3(radiance)}};
  s.ground_radiance_scale = 0.f;
  return s;
}

TEST(DoubleSided, ThePathTracerBouncesOffADoubleSidedBackFace) {
  // 1 m over the ground, looking down: every path hits the ground (but 1e-6 of the cosine
  // lobe, past its 1 km edge) and leaves it upwards to the sky, so E = pi rho L exactly when the
  // ground is a surface, and 0 when what the point sees is the ground's inside.
  constexpr float kL = 2.f, kRho = 0.5f;
  constexpr double kEdgeTolerance = 1e-4;  // the lobe's 1e-6 past the edge, float sums
  reference::ReferenceLighting lighting;
  lighting.sky = uniformSky(kL);
  lighting.hour = 12.0;
  reference::ReferenceQuery q;
  q.position = {0.0, 0.0, 1.0};
  q.normal = {0.f, 0.f, -1.f};
  reference::ReferenceSettings s;
  s.samples = 64;
  for (bool double_sided : {true, false}) {
    const worlds::World w = groundWoundDown(2000.0, glm::dvec3(0.0), double_sided, kRho);
    auto scene = reference::ReferenceScene::build(w, w.name);
    ASSERT_TRUE(scene.has_value()) << scene.error().message;
    const auto e = reference::referenceIrradiance(*scene, lighting, q, s);
    const double want = double_sided ? kPi * kRho * kL : 0.0;
    EXPECT_NEAR(e.ambient.mean.g, want, kEdgeTolerance * kPi * kRho * kL) << w.name;
    EXPECT_EQ(e.parts[reference::kRefDirectSky].mean, glm::vec3(0.f)) << "the ground hides the sky";
  }
}

TEST(DoubleSided, ProbesStandOnADoubleSidedBackFaceAndNotOnAOneSidedOne) {
  // Placement casts rays down and puts probes above the front faces they hit.
  const auto settings = baker::BakeSettings::forQuality(baker::Quality::kDraft);
  size_t probes[2] = {0, 0};
  for (bool double_sided : {true, false}) {
    const worlds::World w = groundWoundDown(64.0, {32.0, 32.0, 0.0}, double_sided, 0.4f);
    auto baked = baker::bakeInMemory(w, w.name, settings, raytrace::SectorRange{0, 0, 0, 0}, 2);
    ASSERT_TRUE(baked.has_value()) << baked.error().message;
    probes[double_sided ? 0 : 1] = baked->probes;
  }
  EXPECT_GT(probes[0], 20u) << "double-sided: the ground is a floor from above";
  EXPECT_EQ(probes[1], 0u) << "one-sided: above it is the ground's inside";
  std::printf("probes on a downward-wound ground: %zu double-sided, %zu one-sided\n", probes[0], probes[1]);
}

}  // namespace
}  // namespace drtv::testing
