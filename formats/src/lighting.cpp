// lighting.cpp — see lighting.h for the references.
#include "drtv/formats/lighting.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "drtv/formats/error.h"

namespace drtv {

glm::vec3 Gradient::at(double hour) const {
  DRTV_CHECK(!keys.empty());
  double h = std::fmod(hour, 24.0);
  if (h < 0) h += 24.0;
  if (!(h >= 0 && h < 24.0)) h = 0;  // NaN or fmod rounding up to 24
  // The last key at or before h, wrapping to the previous day's last key.
  size_t next = 0;
  while (next < keys.size() && keys[next].hour <= h) ++next;
  const ColorKey& a = next == 0 ? keys.back() : keys[next - 1];
  const ColorKey& b = next == keys.size() ? keys.front() : keys[next];
  double ha = a.hour, hb = b.hour;
  if (next == 0) ha -= 24.0;             // before the first key: a is yesterday's last
  if (next == keys.size()) hb += 24.0;   // after the last key: b is tomorrow's first
  const double span = hb - ha;
  if (!(span > 0)) return a.value;       // a single key (span 24 h collapses to 0 only if equal)
  const auto t = static_cast<float>((h - ha) / span);
  return a.value + (b.value - a.value) * t;
}

glm::dvec3 Sky::sunDirection(double hour) const {
  const double hour_angle = (hour - 12.0) * (std::numbers::pi / 12.0);  // 15 deg per hour [1]
  const double sl = std::sin(latitude_rad), cl = std::cos(latitude_rad);
  const double sd = std::sin(declination_rad), cd = std::cos(declination_rad);
  // Local east-north-up components of the unit vector to the sun: morning (h < 0) is east.
  const double east = -cd * std::sin(hour_angle);
  const double north = cl * sd - sl * cd * std::cos(hour_angle);
  const double up = sl * sd + cl * cd * std::cos(hour_angle);
  // North is +Y rotated by north_rad counter-clockwise about Z; east is north turned -90 deg.
  const glm::dvec3 north_axis(-std::sin(north_rad), std::cos(north_rad), 0.0);
  const glm::dvec3 east_axis(std::cos(north_rad), std::sin(north_rad), 0.0);
  return glm::normalize(east * east_axis + north * north_axis + glm::dvec3(0, 0, up));
}

glm::vec3 Sky::skyRadiance(const glm::dvec3& dir, double hour) const {
  const glm::vec3 horizon = sky_horizon.at(hour);
  if (dir.z < 0) return ground_radiance_scale * horizon;
  const auto t = static_cast<float>(std::sqrt(std::min(dir.z, 1.0)));
  return horizon + (sky_zenith.at(hour) - horizon) * t;
}

Sky Sky::tropicalDefault() {
  Sky s;
  // Sun irradiance at normal incidence: white-yellow at noon, orange near the horizon, off at
  // night. Sunrise at this latitude/declination is about 5:45 and sunset about 18:15.
  const glm::vec3 night(0.f), dusk(0.9f, 0.35f, 0.1f), low(2.2f, 1.7f, 1.1f), high(2.9f, 2.75f, 2.4f),
      noon(3.0f, 2.9f, 2.6f);
  s.sun_irradiance.keys = {{0.f, night},  {5.5f, night}, {6.f, dusk},   {7.f, low},  {9.f, high},
                           {12.f, noon},  {15.f, high},  {17.f, low},   {18.f, dusk}, {18.5f, night}};
  // Zenith: half of a saturated sky blue by day, ~0.01 dark blue by night.
  const glm::vec3 zen_night(0.005f, 0.007f, 0.015f), zen_day = glm::vec3(0.25f, 0.45f, 0.9f) * 0.5f,
      zen_dawn(0.06f, 0.08f, 0.15f), zen_dusk(0.08f, 0.07f, 0.14f);
  s.sky_zenith.keys = {{0.f, zen_night}, {5.f, zen_night}, {6.f, zen_dawn}, {8.f, zen_day},
                       {16.f, zen_day},  {18.f, zen_dusk}, {19.f, zen_night}};
  // Horizon: lighter and greyer than the zenith by day, orange at dawn and dusk.
  const glm::vec3 hor_night(0.008f, 0.01f, 0.02f), hor_day(0.35f, 0.42f, 0.55f), hor_dawn(0.5f, 0.25f, 0.1f),
      hor_dusk(0.55f, 0.28f, 0.1f);
  s.sky_horizon.keys = {{0.f, hor_night}, {5.f, hor_night}, {6.f, hor_dawn}, {8.f, hor_day},
                        {16.f, hor_day},  {18.f, hor_dusk}, {19.f, hor_night}};
  return s;
}

namespace {
// "x in [lo, hi]" that NaN fails.
template <class T>
bool within(T x, T lo, T hi) {
  return x >= lo && x <= hi;
}
std::string range(double lo, double hi) {
  std::ostringstream s;
  s << "[" << lo << ", " << hi << "]";
  return s.str();
}
std::string checkGradient(const Gradient& g, const std::string& name) {
  if (g.keys.empty()) return name + ": needs at least one key";
  for (size_t i = 0; i < g.keys.size(); ++i) {
    const ColorKey& k = g.keys[i];
    const std::string at = name + "[" + std::to_string(i) + "]";
    if (!(k.hour >= 0.f && k.hour < 24.f)) return at + ".hour: must be in [0, 24)";
    if (i > 0 && !(g.keys[i - 1].hour < k.hour)) return at + ".hour: hours must increase";
    for (int c = 0; c < 3; ++c)
      if (!within(k.value[c], 0.f, kMaxColourValue)) return at + ".value: colour must be in " + range(0, kMaxColourValue);
  }
  return {};
}
bool inWorld(const glm::dvec3& v) {
  for (int a = 0; a < 3; ++a)
    if (!within(v[a], -kMaxWorldCoordinateM, kMaxWorldCoordinateM)) return false;
  return true;
}
}  // namespace

Result<void> validateLighting(const Sky& sky, const std::vector<PointLight>& lights,
                             const std::vector<InteriorVolume>& interiors) {
  if (!within(sky.latitude_rad, -kMaxLatitudeRad, kMaxLatitudeRad)) return fail("sky.latitude_rad: must be in [-pi/2, pi/2]");
  if (!within(sky.declination_rad, -kMaxDeclinationRad, kMaxDeclinationRad))
    return fail("sky.declination_rad: must be in [-23.5, 23.5] degrees");
  if (!within(sky.north_rad, -kMaxNorthRad, kMaxNorthRad)) return fail("sky.north_rad: must be in [-2 pi, 2 pi]");
  if (!within(sky.ground_radiance_scale, 0.f, 1.f)) return fail("sky.ground_radiance_scale: must be in [0, 1]");
  for (auto [g, name] : {std::pair{&sky.sun_irradiance, "sky.sun_irradiance"}, std::pair{&sky.sky_zenith, "sky.sky_zenith"},
                         std::pair{&sky.sky_horizon, "sky.sky_horizon"}})
    if (std::string e = checkGradient(*g, name); !e.empty()) return fail(e);
  const std::string world = range(-kMaxWorldCoordinateM, kMaxWorldCoordinateM) + " m";
  for (size_t i = 0; i < lights.size(); ++i) {
    const PointLight& l = lights[i];
    const std::string at = "lights[" + std::to_string(i) + "]";
    if (!inWorld(l.position)) return fail(at + ".position: must be in " + world);
    for (int c = 0; c < 3; ++c)
      if (!within(l.intensity[c], 0.f, kMaxColourValue)) return fail(at + ".intensity: must be in " + range(0, kMaxColourValue));
    if (!within(l.radius_m, kMinLightRadiusM, kMaxLightRadiusM))
      return fail(at + ".radius_m: must be in " + range(kMinLightRadiusM, kMaxLightRadiusM) + " m");
  }
  for (size_t i = 0; i < interiors.size(); ++i) {
    const InteriorVolume& v = interiors[i];
    const std::string at = "interiors[" + std::to_string(i) + "]";
    if (!inWorld(v.min)) return fail(at + ".min: must be in " + world);
    if (!inWorld(v.max)) return fail(at + ".max: must be in " + world);
    if (!inWorld(v.probe_position)) return fail(at + ".probe: must be in " + world);
    if (!(v.min.x < v.max.x && v.min.y < v.max.y && v.min.z < v.max.z)) return fail(at + ": min must be < max");
    if (glm::any(glm::lessThan(v.probe_position, v.min)) || glm::any(glm::greaterThan(v.probe_position, v.max)))
      return fail(at + ".probe: must lie inside the box");
    if (!within(v.blend_distance_m, 0.f, kMaxBlendDistanceM))
      return fail(at + ".blend_distance_m: must be in " + range(0, kMaxBlendDistanceM) + " m");
  }
  return {};
}

Result<void> validateLightPath(const LightPath& path) {
  if (path.keys.size() < 2) return fail("keys: a path needs at least 2 keys (a light that stays put needs no path)");
  const std::string world = range(-kMaxWorldCoordinateM, kMaxWorldCoordinateM) + " m";
  for (size_t i = 0; i < path.keys.size(); ++i) {
    const LightKey& k = path.keys[i];
    const std::string at = "keys[" + std::to_string(i) + "]";
    if (!std::isfinite(k.t_s) || (i > 0 && !(k.t_s > path.keys[i - 1].t_s)))
      return fail(at + ".t_s: must be finite" + (i > 0 ? " and greater than keys[" + std::to_string(i - 1) + "].t_s" : std::string()));
    if (!inWorld(k.position)) return fail(at + ".position: must be in " + world);
    for (int c = 0; c < 3; ++c)
      if (!within(k.intensity[c], 0.f, kMaxColourValue)) return fail(at + ".intensity: must be in " + range(0, kMaxColourValue));
    if (!within(k.radius_m, kMinLightRadiusM, kMaxLightRadiusM))
      return fail(at + ".radius_m: must be in " + range(kMinLightRadiusM, kMaxLightRadiusM) + " m");
  }
  return {};
}

PointLight lightAt(const PointLight& light, const LightPath& path, double t_s) {
  DRTV_CHECK_LE(size_t(2), path.keys.size());
  const std::vector<LightKey>& k = path.keys;
  double t = t_s;
  if (path.loop) {
    const double t0 = k.front().t_s, period = k.back().t_s - t0;
    t = t0 + (t - t0 - period * std::floor((t - t0) / period));
  }
  PointLight out = light;
  auto set = [&](const LightKey& a) {
    out.position = a.position, out.intensity = a.intensity, out.radius_m = a.radius_m;
  };
  if (!(t > k.front().t_s)) {
    set(k.front());
    return out;
  }
  if (!(t < k.back().t_s)) {
    set(k.back());
    return out;
  }
  const size_t i = size_t(std::upper_bound(k.begin(), k.end(), t, [](double v, const LightKey& key) { return v < key.t_s; }) - k.begin());
  const LightKey &a = k[i - 1], &b = k[i];
  const double u = (t - a.t_s) / (b.t_s - a.t_s);
  out.position = a.position + (b.position - a.position) * u;
  out.intensity = a.intensity + (b.intensity - a.intensity) * float(u);
  out.radius_m = a.radius_m + (b.radius_m - a.radius_m) * float(u);
  return out;
}

}  // namespace drtv
