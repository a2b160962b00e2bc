// drtv/runtime/lighting_sh.h — time of day -> sun and sky as band-0/1 SH radiance.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 25: the sun and
//      sky colours come from artist gradients over the day and are projected into SH at runtime.
//  [2] Sloan, "Stupid Spherical Harmonics (SH) Tricks", GDC 2008, section "Windowing": scaling
//      band l by a window factor trades ringing for blur (Hanning, Lanczos sigma factors).
//  [3] Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//      SIGGRAPH 2001 (clamped-cosine convolution, A0 = pi, A1 = 2pi/3).
//
// Conventions: sh.h (Z up, [Y00, Y1-1, Y10, Y11], radiance SH). Colours are linear RGB.
//
// Sky (closed form). Sky::skyRadiance is, per channel, L(z) = H + (Z - H) sqrt(z) for z >= 0 and
// g H below the horizon (g = ground_radiance_scale). It does not depend on azimuth, so only Y00
// and Y10 are non-zero. With dw = dz dphi:
//     c0 = Y0 * 2pi * [ H + (Z - H) * 2/3 + g H ]          (int_0^1 sqrt(z) dz   = 2/3)
//     c2 = Y1 * 2pi * [ H/2 + (Z - H) * 2/5 - g H / 2 ]    (int_0^1 z sqrt(z) dz = 2/5)
// The test checks both against sh::projectNumerically.
//
// Direct sky. The baked visibility v[b] is the cosine-weighted share of B_b's whole hemisphere
// that sees the sky: over open ground an upward basis has v = (1 + cos 54.74 deg)/2 = 0.789
// because the ground hides the part of its lobe below the horizon. Masking the sky SH with
// g = 0 by v would remove that part twice (0.789^2: -30 % of the ambient on the test scenes,
// docs/reference.md). The direct-sky term therefore masks the sky continued through the horizon
// with the horizon colour (g = 1): exact for a uniform sky over a plane, and the ground's own
// light comes back through the bounce transfer. The sky bounce keeps g, the sky as it is.
//
// Sun (windowed delta). The sun is a delta of irradiance E from direction d: SH E Y(d). Band 1
// is scaled by a window factor w1 [2]. Why: the sun enters relighting only through the transfer
// vectors, dot(SunSH, T), and DESIGN.md clamps ringing only at the end of a probe's sum, so a
// negative sun term would eat the sky terms of the same basis (dawn darker than night). A bounced
// irradiance transfer is close to a non-negative mix of clamped-cosine lobes; for one lobe about m
// the sun term is E (1/4 + w1/2 cos(d, m)), non-negative for every sun direction iff w1 <= 1/2.
// The default is therefore the Hanning window, w1 = (1 + cos(pi/2)) / 2 = 1/2. Lanczos
// (sigma = sinc(1/2) = 2/pi) rings to -0.068 E and the raw delta (w1 = 1, the L2-optimal fit) to
// -0.25 E. Band 0 is never scaled, so the sun's energy (its mean irradiance) is exact.
//
// The linear sun (band0_scale 0, band1_window 2; measured for sh-l1, docs/accuracy.md "Sun"):
// SH E [0, 2 Y1 d], so that a transfer equal to one clamped-cosine lobe about m gives E cos(d, m):
// exact on every unshadowed surface that faces the sun (the ground under a sun at any elevation,
// where the windowed lobe gives E (1 + sin e) / 4, -50 % at noon), -E |cos| on those facing away
// (which the end-of-sum clamp does not undo). Not energy-conserving over all orientations; it
// trades the windowed lobe's error on lit surfaces for one on surfaces facing away.
//
// Sun below the horizon: the sun is faded out smoothly as its centre goes from 2 deg above to
// 0.83 deg below the horizon (0.83 deg = atmospheric refraction 0.57 deg + the sun's semi-diameter
// 0.27 deg, the standard "sunset" elevation), so that a gradient that still has sun colour after
// sunset does not light the world from below, and so that sunset is not a one-frame pop.
#pragma once

#include <span>

#include <glm/glm.hpp>

#include "drtv/formats/lighting.h"
#include "drtv/formats/sh.h"

namespace drtv::runtime {

inline constexpr float kHanningBand1 = 0.5f;             // (1 + cos(pi/2)) / 2
inline constexpr float kLanczosBand1 = 0.636619772f;     // sinc(1/2) = 2 / pi
inline constexpr float kNoWindowBand1 = 1.f;
inline constexpr float kLinearSunBand1 = 2.f;   // with band0_scale 0: the linear sun (above)
inline constexpr double kSunFadeTopRad = 0.0349066;      // 2 deg: fully on above this elevation
inline constexpr double kSunFadeBottomRad = -0.0144862;  // -0.83 deg: fully off below this

// Closed-form SH of the sky gradient for one channel: zenith radiance `zenith`, horizon radiance
// `horizon` (per sr), radiance `ground_scale * horizon` below the horizon. Pure, thread-safe.
sh::Sh4 projectSkyGradient(float zenith, float horizon, float ground_scale);
// The same for each of R, G, B.
sh::Sh4Rgb projectSkyGradient(const glm::vec3& zenith, const glm::vec3& horizon, float ground_scale);

// SH of a sun of irradiance `irradiance` (at normal incidence) arriving from unit direction `dir`
// (towards the sun), band 1 scaled by `band1_window` in [0, 2] (above 1 only for the linear sun),
// band 0 by `band0_scale` in [0, 1]. Pure, thread-safe.
sh::Sh4Rgb projectSun(const glm::vec3& dir, const glm::vec3& irradiance, float band1_window, float band0_scale = 1.f);

// The sun's below-horizon fade in [0, 1] for a sun at elevation `elevation_rad` (smoothstep from
// kSunFadeBottomRad to kSunFadeTopRad). NaN reads as 0.
float sunHorizonFade(double elevation_rad);

// Everything the relighting needs about the sun and sky at one time of day.
struct SkyLighting {
  double hour = 0.0;                // the hour evaluated, in [0, 24)
  glm::vec3 sun_direction{0, 0, 1}; // unit, towards the sun; z < 0 when it has set
  float sun_fade = 0.f;             // sunHorizonFade of the sun's elevation
  glm::vec3 sun_irradiance{0.f};    // gradient value times sun_fade (linear RGB)
  glm::vec3 sky_zenith{0.f};        // radiance per sr
  glm::vec3 sky_horizon{0.f};       // radiance per sr
  float ground_radiance_scale = 0.f;
  sh::Sh4Rgb sky_sh{};              // radiance SH of the sky (with ground term)
  sh::Sh4Rgb sky_direct_sh{};       // the sky continued through the horizon (g = 1): what the
                                    // baked visibility v[b] masks (see "Direct sky" above)
  sh::Sh4Rgb sun_sh{};              // radiance SH of the windowed sun
};

// Evaluates `sky` at `hour` (any finite real, taken modulo 24). Precondition: `sky` passed
// validateLighting and `hour` is finite (bugs otherwise; Runtime checks both and returns errors).
// Thread-safe.
SkyLighting evaluateSky(const Sky& sky, double hour, float band1_window = kHanningBand1, float band0_scale = 1.f);

// Weights of a sun transfer's samples (sector.h SunBlock) for the sun in unit direction `d`:
// the samples are a path of directions; of its segments (consecutive samples, and last-to-first
// when they close a ring, as under a midnight sun) the one whose great-circle detour through d is
// shortest is interpolated by angle, w_a = 1 - t, w_b = t, and both are faded to 0 as the detour
// grows to the segment's length (a sun off the baked path gets no correction). `w` receives
// samples.size() weights (at most two non-zero), summing to at most 1. Thread-safe.
void sunTransferWeights(std::span<const glm::vec3> samples, const glm::vec3& d, std::span<float> w);

// How far lighting moved from `from` to `to`: the largest absolute change of any sky or sun SH
// coefficient divided by the largest band-0 coefficient of either (so 1/255 is about one step of
// an 8-bit texel scaled to the brightest light). 0 when both are black. Thread-safe.
float lightingChange(const SkyLighting& from, const SkyLighting& to);

}  // namespace drtv::runtime
