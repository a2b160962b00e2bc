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

void sunTransferWeights(std::span<const glm::vec3> samples, const glm::vec3& d, std::span<float> w) {
  DRTV_CHECK_EQ(w.size(), samples.size());
  std::fill(w.begin(), w.end(), 0.f);
  const size_t K = samples.size();
  if (K < 2 || !(std::isfinite(d.x) && std::isfinite(d.y) && std::isfinite(d.z))) return;
  // atan2 of sine and cosine: exact near 0, where acos of a dot product loses half its digits.
  auto angle = [](const glm::vec3& a, const glm::vec3& b) { return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b)); };
  float longest = 0.f;
  for (size_t k = 0; k + 1 < K; ++k) longest = std::max(longest, angle(samples[k], samples[k + 1]));
  const bool ring = K > 2 && angle(samples[K - 1], samples[0]) <= 1.5f * longest;
  float best_detour = INFINITY, best_t = 0.f, best_len = 0.f;
  size_t best_a = 0, best_b = 1;
  for (size_t k = 0; k < (ring ? K : K - 1); ++k) {
    const size_t b = (k + 1) % K;
    const float len = angle(samples[k], samples[b]), da = angle(d, samples[k]), db = angle(d, samples[b]);
    const float detour = da + db - len;
    if (detour < best_detour) {
      best_detour = detour, best_a = k, best_b = b, best_len = len;
      best_t = da + db > 0.f ? da / (da + db) : 0.f;
    }
  }
  if (!(best_len > 0.f)) return;
  const float fade = std::clamp(1.f - best_detour / best_len, 0.f, 1.f);
  w[best_a] += (1.f - best_t) * fade;
  w[best_b] += best_t * fade;
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
