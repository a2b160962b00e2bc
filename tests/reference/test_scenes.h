// Small worlds and skies with known answers, shared by the reference tests.
#pragma once

#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "drtv/formats/effects.h"
#include "drtv/formats/lighting.h"
#include "drtv/worlds/world.h"

namespace drtv::testing {

// (1 + cos 54.7356 deg) / 2: the cosine-weighted fraction of the hemisphere about an upward
// transfer basis (elevation 35.26 deg, DESIGN.md) that lies above an infinite horizontal plane.
inline constexpr double kUpBasisSkyFraction = (1.0 + 0.5773502691896258) / 2.0;
inline constexpr double kPi = 3.14159265358979323846;

// A square of side `size_m` in the plane z = `z`, facing +Z, centred on `centre` (x, y).
inline worlds::World planeWorld(double size_m, const glm::vec3& albedo, const glm::dvec3& centre = glm::dvec3(0.0)) {
  worlds::World w;
  w.name = "plane";
  worlds::Mesh m;
  m.name = "plane";
  const float h = float(size_m / 2);
  m.positions = {{-h, -h, 0.f}, {h, -h, 0.f}, {h, h, 0.f}, {-h, h, 0.f}};
  m.indices = {0, 1, 2, 0, 2, 3};
  m.albedo = albedo;
  w.meshes.push_back(m);
  worlds::Instance inst;
  inst.mesh = 0;
  inst.transform = glm::dmat4(1.0);
  inst.transform[3] = glm::dvec4(centre, 1.0);
  inst.cls = worlds::InstanceClass::kTerrain;
  inst.name = "plane";
  w.instances.push_back(inst);
  w.effects = kEffectSunBounce | kEffectSkyBounce | kEffectDirectSky;
  w.effects_explicit = true;
  return w;
}

// A constant gradient.
inline Gradient constant(const glm::vec3& v) { return Gradient{{ColorKey{0.f, v}}}; }

// Radiance L everywhere above the horizon and `ground_scale` L below; no sun.
inline Sky uniformSky(float L, float ground_scale) {
  Sky s;
  s.sun_irradiance = constant(glm::vec3(0.f));
  s.sky_zenith = constant(glm::vec3(L));
  s.sky_horizon = constant(glm::vec3(L));
  s.ground_radiance_scale = ground_scale;
  return s;
}

// A black sky and a white sun of irradiance E whose noon elevation is `elevation_deg` (to the
// south): latitude - declination = 90 - elevation at hour 12.
inline Sky sunOnlySky(float E, double elevation_deg) {
  Sky s;
  s.sun_irradiance = constant(glm::vec3(E));
  s.sky_zenith = constant(glm::vec3(0.f));
  s.sky_horizon = constant(glm::vec3(0.f));
  s.declination_rad = 0.0;
  s.latitude_rad = (90.0 - elevation_deg) * kPi / 180.0;
  return s;
}

}  // namespace drtv::testing
