// drtv/sweep/directions.h — the 26 light directions of the top-down sweep light grid (seed 001),
// the part of the sphere each one stands for, and the sky and sun as seen by them.
//
//  [1] ../shared/seeds/001 ("Light grid format", "Tracing light flow"): 26 directions per cell,
//      the axes and the diagonals; 17 of them feed the next level down (straight down, 8
//      diagonals, 8 near-horizontal directions crossing 4 cells per level); the sun is a bright
//      disc in the sky, no shadow maps.
//
// Conventions (DESIGN.md): Z up, metres, linear RGB. A direction is named by the way its light
// TRAVELS (`step`), and it stands for a bin of the sphere of directions the light COMES FROM:
//   index 0..8    down:   step (dx, dy, -1), dx, dy in {-1, 0, 1}, index (dy + 1) * 3 + (dx + 1)
//   index 9..16   near-horizontal: nominal step (dx, dy, 0), (dx, dy) != 0 in the same order; the
//                 sweep moves their light 4 cells sideways per level down ([1]), i.e. along
//                 (4 dx, 4 dy, -1): they are the sky just above the horizon
//   index 17..25  up:     step (dx, dy, +1), in the same order as down
// The bins: every direction with z > 0 (light from above) belongs to the nearest of the 17
// down-going directions' source directions (-travel), every direction with z < 0 to the nearest
// of the 9 up-going ones. So the bins partition the sphere, none straddles the horizon, and a
// light value per bin is exact where the sky is uniform within each bin.
//
// Units: a light value is Phi_k = integral over bin k of L(w) dw (radiance L [per sr] times solid
// angle: W/m^2-like, the sky's units without the per sr). Irradiance on a unit normal n is then
//   E(n) = sum_k Phi_k max(0, n . m_k),  m_k = (1 / Omega_k) integral over bin k of w dw,
// the bin's mean source direction (|m_k| < 1). It is exact for any n that sees the whole of the
// bins it weighs, e.g. E(+Z) = pi L under a uniform sky L (the quadrature below is the midpoint
// rule in z, exact for the cosine).
//
// Thread-safety: directions() is computed once (function-local static) and read-only after.
#pragma once

#include <array>

#include <glm/glm.hpp>

#include "drtv/formats/lighting.h"

namespace drtv::sweep {

inline constexpr int kDirections = 26;
inline constexpr int kDown = 9;                 // indices [0, 9)
inline constexpr int kNearHorizontal = 8;       // indices [9, 17)
inline constexpr int kSwept = kDown + kNearHorizontal;  // 17: what flows from one level to the next
inline constexpr int kUp = 9;                   // indices [17, 26)
inline constexpr int kNearHorizontalStep = 4;   // cells sideways per level down [1]

using LightVector = std::array<glm::vec3, kDirections>;  // Phi_k, linear RGB

struct Direction {
  glm::ivec3 step{0};       // nominal travel, a cube offset (see the header)
  glm::ivec3 sweep_step{0}; // what the sweep moves per level: step, or (4dx, 4dy, -1) near-horizontal
  glm::vec3 travel{0.f};    // unit mean travel direction of the bin (-m_k normalised)
  glm::vec3 mean_from{0.f}; // m_k: the bin's mean source direction, |m_k| < 1
  float solid_angle_sr = 0; // Omega_k; the 26 sum to 4 pi
};

// The 26 directions in the order of the header.
const std::array<Direction, kDirections>& directions();

// Irradiance on unit normal `n` from light values `phi`: sum_k phi[k] max(0, n . m_k).
glm::vec3 irradiance(const LightVector& phi, const glm::vec3& n);

// The sky's light per bin at `hour` (Sky::skyRadiance integrated over each bin; below the horizon
// ground_radiance_scale x horizon, which only the up-going bins see), without the sun.
LightVector skyLight(const Sky& sky, double hour);

// The sun as a bright disc of angular radius `disc_radius_rad` about Sky::sunDirection(hour): its
// irradiance at normal incidence, Sky::sun_irradiance.at(hour), shared among the bins the disc
// covers (by the quadrature's share of the disc in each). All zero when the sun is at or below the
// geometric horizon (as the reference's, reference.h). disc_radius_rad in (0, pi/4].
LightVector sunLight(const Sky& sky, double hour, double disc_radius_rad);

}  // namespace drtv::sweep
