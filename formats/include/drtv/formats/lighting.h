// drtv/formats/lighting.h — the world's lighting description: sun path and sky gradients over the
// 24 h day, dynamic point lights and interior volumes. The baker reads it from the World, the
// archive manifest stores it, and the runtime evaluates it, so relighting needs no world file.
//
//  [1] Michalsky, "The Astronomical Almanac's algorithm for approximate solar position", Solar
//      Energy 40(3), 1988 — the hour-angle / declination / latitude model.
//  [2] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 25 (artist
//      gradients of sun and sky colour driven by the time of day), slides 11-12 (dynamic lights),
//      slide 55 (interiors).
//
// Conventions: Z up, metres, linear RGB. Hours are real numbers taken modulo 24.
#pragma once

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"

namespace drtv {

// The range of every float a lighting description carries, on load and on write (archive
// manifests, world files; docs/formats.md "Value ranges"). Finite is not enough: a colour of 3e38
// is finite, but sun plus sky overflows to Inf and the runtime's ambient to NaN. With these bounds
// the runtime's largest sum (colour x transfer range x terms, probe.h) stays below 1e16, far from
// FLT_MAX (3.4e38).
inline constexpr float kMaxColourValue = 1e9f;          // gradient colours, light intensities (linear RGB)
inline constexpr double kMaxWorldCoordinateM = 1e8;     // |x|, |y|, |z| of positions and boxes, metres
inline constexpr float kMinLightRadiusM = 1e-3f;        // PointLight::radius_m in [1e-3, 1e5] m
inline constexpr float kMaxLightRadiusM = 1e5f;
inline constexpr float kMaxBlendDistanceM = 1e4f;       // InteriorVolume::blend_distance_m in [0, 1e4] m
// Sun path angles, radians: latitude in [-90, 90] deg, declination in [-23.5, 23.5] deg (the
// Earth's tilt), north in [-360, 360] deg; each with 1e-9 rad of slack for the degree conversion.
inline constexpr double kMaxLatitudeRad = 1.5707963267948966 + 1e-9;
inline constexpr double kMaxDeclinationRad = 0.41015237421866746 + 1e-9;
inline constexpr double kMaxNorthRad = 6.283185307179586 + 1e-9;

// A key of a piecewise-linear gradient over the day.
struct ColorKey {
  float hour = 0;        // [0, 24)
  glm::vec3 value{0.f};  // linear RGB, >= 0
};

// A piecewise-linear gradient over the 24 h day; it wraps at midnight.
struct Gradient {
  std::vector<ColorKey> keys;  // sorted by hour, at least one
  // Value at `hour` (any real; taken modulo 24; NaN reads as 0 h), linear between keys.
  // Precondition: at least one key (a bug otherwise). Thread-safe.
  glm::vec3 at(double hour) const;
};

// Sun and sky over the day [1, 2].
struct Sky {
  // Sun path: hour angle h = (hour - 12) * 15 deg; elevation asin(sin(lat) sin(dec) +
  // cos(lat) cos(dec) cos(h)). North is +Y and east +X, both rotated by `north_rad` about Z.
  double latitude_rad = 0.3;      // ~17 deg N, a tropical island
  double declination_rad = 0.2;   // ~11.5 deg: a late-spring day
  double north_rad = 0.0;         // rotation of north away from +Y, counter-clockwise about Z
  Gradient sun_irradiance;        // irradiance at normal incidence (linear RGB)
  Gradient sky_zenith;            // sky radiance straight up (per sr)
  Gradient sky_horizon;           // sky radiance at the horizon (per sr)
  float ground_radiance_scale = 0.0f;  // radiance below the horizon, as a fraction of the horizon's

  // Unit vector towards the sun at `hour` (Z up). Below-horizon directions are returned as they
  // are (z < 0): callers decide what a set sun means.
  glm::dvec3 sunDirection(double hour) const;
  // Sky radiance in unit direction `dir` at `hour`: the horizon colour at z = 0 blended to the
  // zenith colour as sqrt(z) for z >= 0; below the horizon ground_radiance_scale * horizon.
  glm::vec3 skyRadiance(const glm::dvec3& dir, double hour) const;
  // The default tropical day used when a world says nothing about its sky.
  static Sky tropicalDefault();
};

// A dynamic point light (talk slides 11-12; LPRT). World metres.
struct PointLight {
  std::string name;
  glm::dvec3 position{0.0};
  glm::vec3 intensity{1.f};  // radiant intensity, linear RGB per sr (>= 0)
  float radius_m = 10.f;     // range of influence, > 0
};

// A light that moves (a carried torch, a vehicle's lamps, a flickering fire): keys in time, the
// light's state between two keys linear in time. LPRT does not care where a light is (its sources
// are probes), so a baked world takes moving lights without a rebake; the runtime redistributes
// them onto source probes each time they are set.
struct LightKey {
  double t_s = 0.0;             // seconds from the start of the animation, strictly increasing
  glm::dvec3 position{0.0};     // world metres
  glm::vec3 intensity{1.f};     // radiant intensity, linear RGB per sr (>= 0)
  float radius_m = 10.f;        // range of influence, > 0
};
struct LightPath {
  std::vector<LightKey> keys;   // >= 2 keys
  bool loop = false;            // after the last key, start again from the first (period: the
                                // last key's time; the last key should repeat the first's state)
};

// The light `light` following `path` at time `t_s` (any finite seconds): clamped to the first
// and last keys, or wrapped with `loop`. Precondition: validateLightPath(path) holds.
PointLight lightAt(const PointLight& light, const LightPath& path, double t_s);
// What is wrong with a path, as an error (nothing when it is sound): "keys: a path needs at least 2 keys", "keys[3].t_s:
// must be finite and greater than keys[2].t_s", and every key's position, intensity and radius in
// the ranges validateLighting holds a light to.
Result<void> validateLightPath(const LightPath& path);

// An artist volume whose inside takes ambient from one designated probe (talk slide 55).
struct InteriorVolume {
  std::string name;
  glm::dvec3 min{0.0}, max{0.0};      // world-space axis-aligned box, min < max
  glm::dvec3 probe_position{0.0};     // the designated probe, inside the box
  float blend_distance_m = 1.f;       // soft transition width at the box faces, >= 0
};

// What is wrong with a lighting description, as an error (nothing when it is sound): gradients non-empty with
// sorted hours in [0, 24) and colours in [0, kMaxColourValue]; angles in their ranges above;
// ground_radiance_scale in [0, 1]; lights with positions within kMaxWorldCoordinateM, intensity
// in [0, kMaxColourValue] and radius in [kMinLightRadiusM, kMaxLightRadiusM]; interiors within
// kMaxWorldCoordinateM with min < max, the probe inside and a blend distance in [0,
// kMaxBlendDistanceM]. NaN fails every check. Names the offending item and field
// ("sky.sun_irradiance[2].value", "lights[0].intensity").
Result<void> validateLighting(const Sky& sky, const std::vector<PointLight>& lights,
                             const std::vector<InteriorVolume>& interiors);

}  // namespace drtv
