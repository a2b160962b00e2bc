// Emissive surfaces as the bake and the path tracer see them (world.h, emissiveLights): point
// lights carrying the emitter's flux, measured against the true area light, and the Cornell box,
// whose only light is its emissive quad, lit by it at night in the reference and in the bake.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "drtv/baker/bake.h"
#include "drtv/reference/reference.h"
#include "drtv/worlds/load.h"

namespace drtv::testing {
namespace {

constexpr double kPi = std::numbers::pi;

// A square quad of side `side` centred on (0, 0, z), front face up (+z) or down.
worlds::Mesh square(const std::string& name, double side, double z, bool up) {
  worlds::Mesh m;
  m.name = name;
  const float s = float(side / 2), h = float(z);
  m.positions = {{-s, -s, h}, {s, -s, h}, {s, s, h}, {-s, s, h}};
  m.indices = up ? std::vector<uint32_t>{0, 1, 2, 0, 2, 3} : std::vector<uint32_t>{0, 2, 1, 0, 3, 2};
  return m;
}

// A small emitter of radiance kLe and side kSide, kHeight above a black ground (no bounce).
constexpr double kLe = 1000.0, kSide = 0.2, kHeight = 5.0, kGroundSide = 20000.0;
worlds::World emitterOverGround() {
  worlds::World w;
  w.name = "emitter over ground";
  worlds::Mesh ground = square("ground", kGroundSide, 0.0, true);
  ground.albedo = glm::vec3(0.f);
  worlds::Mesh lamp = square("lamp", kSide, kHeight, false);
  lamp.albedo = glm::vec3(0.f);
  lamp.emission = glm::vec3(float(kLe));
  w.meshes = {ground, lamp};
  w.instances = {{0, glm::dmat4(1.0), worlds::InstanceClass::kTerrain, "ground"},
                 {1, glm::dmat4(1.0), worlds::InstanceClass::kStatic, "lamp"}};
  worlds::emissiveLights(w);
  return w;
}

// The true irradiance at ground point (x, 0, 0), normal +z, from the Lambertian square emitter:
// sum over n x n cells of Le cos_e cos_r dA / r^2 (the slow, obviously correct reference).
double areaLightIrradiance(double x, int n = 400) {
  double e = 0.0;
  const double cell = kSide / n;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const glm::dvec3 p(-kSide / 2 + (i + 0.5) * cell, -kSide / 2 + (j + 0.5) * cell, kHeight);
      const glm::dvec3 d = p - glm::dvec3(x, 0.0, 0.0);
      const double r2 = glm::dot(d, d), r = std::sqrt(r2);
      const double cos_r = d.z / r, cos_e = d.z / r;  // the emitter faces -z, the receiver +z
      e += kLe * cos_e * cos_r * cell * cell / r2;
    }
  return e;
}

// A point light's irradiance reaches a ground point through the path tracer's own shadow ray.
double pathTracerDirect(const reference::ReferenceScene& scene, const reference::ReferenceLighting& lighting, double x,
                        double y = 0.0) {
  return reference::directIrradiance(scene.rays(), scene.origin(), lighting, {x, y, 0.0}, {0.f, 0.f, 1.f}).lights.g;
}

reference::ReferenceLighting nightLighting(const worlds::World& w) {
  reference::ReferenceLighting l;
  l.sky = w.sky;
  l.hour = 0.0;  // midnight: the sun is down
  l.lights = w.lights;
  return l;
}

TEST(EmissiveLights, CarryTheEmittersFluxAndMatchItSixtyDegreesOffItsNormal) {
  const worlds::World w = emitterOverGround();
  ASSERT_EQ(w.lights.size(), 1u) << "0.04 m^2, flat: one light";
  auto scene = reference::ReferenceScene::build(w, "emitter");
  ASSERT_TRUE(scene.has_value()) << scene.error().message;
  const auto lighting = nightLighting(w);

  // Straight below: an isotropic light of the same flux gives half the cosine emitter's
  // irradiance (far field: the 0.2 m emitter is 25 times closer to a point than to the ground).
  constexpr double kFarFieldTolerance = 0.01;  // the light 1 cm off its emitter (0.4 %), the emitter's size (~0.1 %)
  const double below = pathTracerDirect(*scene, lighting, 0.0) / areaLightIrradiance(0.0);
  EXPECT_NEAR(below, 0.5, kFarFieldTolerance) << "straight below: point / area";
  // 60 degrees off the emitter's normal the cosine is 1/2: the two agree.
  const double x60 = kHeight * std::tan(kPi / 3);
  const double at60 = pathTracerDirect(*scene, lighting, x60) / areaLightIrradiance(x60);
  EXPECT_NEAR(at60, 1.0, kFarFieldTolerance) << "60 degrees: point / area";
  std::printf("point lights / true area light: %.4f straight below, %.4f at 60 degrees\n", below, at60);

  // The flux onto the ground (r up to 1000 heights, rings in log r) is the emitter's pi Le A:
  // I = Le A / 2 into the lower half-space. Within R the point light puts 1 - h / sqrt(R^2 + h^2)
  // of it (0.1 % short at R = 1000 h), the area light R^2 / (R^2 + h^2).
  constexpr int kRings = 4000;
  const double r0 = 1e-3 * kHeight, r1 = 1e3 * kHeight;
  double flux = 0.0;
  for (int i = 0; i < kRings; ++i) {
    const double a = r0 * std::pow(r1 / r0, double(i) / kRings), b = r0 * std::pow(r1 / r0, double(i + 1) / kRings);
    const double r = std::sqrt(a * b);
    flux += pathTracerDirect(*scene, lighting, r) * kPi * (b * b - a * a);
  }
  const double want = kPi * kLe * kSide * kSide;
  constexpr double kFluxTolerance = 0.004;  // the 0.1 % beyond R, the log-ring quadrature's ~0.1 %
  EXPECT_NEAR(flux / want, 1.0, kFluxTolerance) << "flux onto the ground " << flux << " W vs pi Le A " << want << " W";
  std::printf("flux onto the ground: %.4f of pi Le A\n", flux / want);
}

// Bevy's Cornell box has no light but its emissive quad (130 x 105 under the ceiling, Le 100).
TEST(EmissiveLights, TheCornellBoxIsLitByItsQuadAtNight) {
  auto w = worlds::loadWorld(DRTV_TEST_ASSETS "/cornell_bevy/CornellBox.glb");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_FALSE(w->lights.empty()) << "the quad made no light";
  auto scene = reference::ReferenceScene::build(*w, "CornellBox.glb");
  ASSERT_TRUE(scene.has_value()) << scene.error().message;
  const auto lighting = nightLighting(*w);
  ASSERT_EQ(reference::referenceSun(lighting.sky, lighting.hour).irradiance, glm::vec3(0.f));
  // The floor (glTF y = 0) in the front-left, clear of both blocks: drtv (x, -z_gltf, y_gltf).
  reference::ReferenceQuery q;
  q.position = {-100.0, 450.0, 0.0};
  q.normal = {0.f, 0.f, 1.f};
  reference::ReferenceSettings s;
  s.samples = 256;
  const auto lit = reference::referenceIrradiance(*scene, lighting, q, s);
  const reference::Estimate direct = lit.parts[reference::kRefDirectLocal];
  const reference::Estimate bounce = lit.parts[reference::kRefLocalLights];
  EXPECT_GT(direct.mean.g, 0.f) << "the floor sees the quad's lights";
  EXPECT_GT(bounce.mean.g, 4.f * bounce.std_error.g) << "and their bounce off the walls";
  std::printf("Cornell floor at midnight: direct %.4g, bounce %.4g +- %.2g (W/m^2)\n", direct.mean.g, bounce.mean.g,
              bounce.std_error.g);
  // Without them, nothing.
  reference::ReferenceLighting dark = lighting;
  dark.lights.clear();
  const auto unlit = reference::referenceIrradiance(*scene, dark, q, s);
  EXPECT_EQ(unlit.parts[reference::kRefDirectLocal].mean, glm::vec3(0.f));
  EXPECT_EQ(unlit.parts[reference::kRefLocalLights].mean, glm::vec3(0.f));
}

TEST(EmissiveLights, TheCornellWorldBakesLprtWithoutItsLamp) {
  auto w = worlds::loadWorld(DRTV_SOURCE_DIR "/tests/reference/data/cornell_world.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  // Only the quad's lights: the world file's lamp is lights[0].
  ASSERT_EQ(w->lights.at(0).name, "lamp");
  w->lights.erase(w->lights.begin());
  w->light_paths.erase(w->light_paths.begin());
  w->effects = worlds::defaultEffects(*w);
  ASSERT_TRUE(w->effects & kEffectLocalLights) << "emissive lights alone call for LPRT";
  const auto settings = baker::BakeSettings::forQuality(baker::Quality::kDraft);
  auto baked = baker::bakeInMemory(*w, "cornell_world.json", settings, std::nullopt, 2);
  ASSERT_TRUE(baked.has_value()) << baked.error().message;
  EXPECT_TRUE(baked->manifest.effects & kEffectLocalLights);
  EXPECT_EQ(baked->manifest.lights.size(), w->lights.size());
  size_t with_lprt = 0;
  for (const Sector& sector : baked->sectors) with_lprt += sector.hasLprt();
  EXPECT_GT(with_lprt, 0u) << "LPRT sources for the quad's light";
}

}  // namespace
}  // namespace drtv::testing
