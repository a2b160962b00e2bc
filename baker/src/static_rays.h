// Private to the baker: what its ray casts share. Static and terrain geometry stop a ray;
// vegetation and dynamic objects are passed through (the talk's placement passes leaves [1, slide
// 16], and nothing baked may depend on what moves).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/worlds/world.h"

namespace drtv::baker::detail {

inline bool isStatic(uint8_t cls) {
  return cls == uint8_t(worlds::InstanceClass::kTerrain) || cls == uint8_t(worlds::InstanceClass::kStatic);
}

// Step past a hit before looking for the next one along the same ray: 0.1 mm, far below modelled
// thickness and far above float round-off at sector coordinates.
inline constexpr float kHitStepM = 1e-4f;
// Where a ray continues after a hit at distance t: kHitStepM further, or more where floats are
// coarser than that (beyond ~2 km a 0.1 mm step would round back onto the same hit).
inline float nextRayStart(float t) { return std::max(t + kHitStepM, std::nextafter(t, INFINITY) * (1.f + 1e-6f)); }

// The distance along `dir` from `origin` to the first static or terrain surface within `len`,
// passing at most `max_hits` other hits; INFINITY if none. Counts each cast in `rays`.
inline float staticHitDistance(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, const glm::vec3& origin,
                               const glm::vec3& dir, float len, int max_hits, uint64_t& rays) {
  float t = 0.f;
  for (int k = 0; k < max_hits; ++k) {
    const raytrace::Hit h = scene.intersect(raytrace::Ray{origin, t, dir, len});
    ++rays;
    if (!h.hit()) return INFINITY;
    if (isStatic(geometry.cls[h.prim])) return h.t;
    t = nextRayStart(h.t);
  }
  return INFINITY;
}

// Direction i of n on the Fibonacci sphere (González, "Measurement of areas on a sphere using
// Fibonacci and latitude-longitude lattices", Mathematical Geosciences 42, 2010): evenly spread,
// z from 1 - 1/n down to -1 + 1/n.
inline glm::vec3 fibonacciDirection(int i, int n) {
  const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 3.14159265358979 * (3.0 - std::sqrt(5.0)) * i;
  return glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

}  // namespace drtv::baker::detail
