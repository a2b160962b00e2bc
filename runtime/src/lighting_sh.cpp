// lighting_sh.cpp — see lighting_sh.h for the references and the derivations.
#include "drtv/runtime/lighting_sh.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "drtv/formats/error.h"

namespace drtv::runtime {

sh::Sh4 projectSkyGradient(float zenith, float horizon, float ground_scale) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  const double h = horizon, dz = double(zenith) - double(horizon), g = ground_scale;
  const double c0 = sh::kY0 * kTwoPi * (h + dz * (2.0 / 3.0) + g * h);
  const double c2 = sh::kY1 * kTwoPi * (h * 0.5 + dz * 0.4 - g * h * 0.5);
  return {float(c0), 0.f, float(c2), 0.f};
}

sh::Sh4Rgb projectSkyGradient(const glm::vec3& zenith, const glm::vec3& horizon, float ground_scale) {
  sh::Sh4Rgb out;
  for (int c = 0; c < 3; ++c) out[c] = projectSkyGradient(zenith[c], horizon[c], ground_scale);
  return out;
}

sh::Sh4Rgb projectSun(const glm::vec3& dir, const glm::vec3& irradiance, float band1_window, float band0_scale) {
  sh::Sh4 basis = sh::evaluate(dir);
  basis.x *= band0_scale;
  basis.y *= band1_window;
  basis.z *= band1_window;
  basis.w *= band1_window;
  return {basis * irradiance.r, basis * irradiance.g, basis * irradiance.b};
}

float sunHorizonFade(double elevation_rad) {
  const double t = (elevation_rad - kSunFadeBottomRad) / (kSunFadeTopRad - kSunFadeBottomRad);
  if (!(t > 0.0)) return 0.f;  // also NaN
  if (t >= 1.0) return 1.f;
  return float(t * t * (3.0 - 2.0 * t));
}

SkyLighting evaluateSky(const Sky& sky, double hour, float band1_window, float band0_scale) {
  DRTV_CHECK(std::isfinite(hour));
  SkyLighting s;
  double h = std::fmod(hour, 24.0);
  if (h < 0) h += 24.0;
  if (h >= 24.0) h = 0.0;
  s.hour = h;
  const glm::dvec3 d = sky.sunDirection(h);
  s.sun_direction = glm::vec3(d);
  s.sun_fade = sunHorizonFade(std::asin(std::clamp(d.z, -1.0, 1.0)));
  s.sun_irradiance = sky.sun_irradiance.at(h) * s.sun_fade;
  s.sky_zenith = sky.sky_zenith.at(h);
  s.sky_horizon = sky.sky_horizon.at(h);
  s.ground_radiance_scale = sky.ground_radiance_scale;
  s.sky_sh = projectSkyGradient(s.sky_zenith, s.sky_horizon, s.ground_radiance_scale);
  s.sky_direct_sh = projectSkyGradient(s.sky_zenith, s.sky_horizon, 1.f);
  s.sun_sh = projectSun(s.sun_direction, s.sun_irradiance, band1_window, band0_scale);
  return s;
}

float lightingChange(const SkyLighting& from, const SkyLighting& to) {
  float scale = 0.f, change = 0.f;
  for (int c = 0; c < 3; ++c) {
    scale = std::max({scale, std::fabs(from.sky_sh[c][0]), std::fabs(to.sky_sh[c][0]), std::fabs(from.sun_sh[c][0]),
                      std::fabs(to.sun_sh[c][0])});
    for (int k = 0; k < 4; ++k)
      change = std::max({change, std::fabs(from.sky_sh[c][k] - to.sky_sh[c][k]), std::fabs(from.sun_sh[c][k] - to.sun_sh[c][k]),
                         std::fabs(from.sky_direct_sh[c][k] - to.sky_direct_sh[c][k])});
  }
  if (!(scale > 0.f)) return change > 0.f ? 1.f : 0.f;
  return change / scale;
}

}  // namespace drtv::runtime
