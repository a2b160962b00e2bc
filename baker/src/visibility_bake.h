// visibility_bake.h — the depth-moment maps of covered probes (drtv/formats/visibility.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {

// Rays per probe: about 28 within each texel's filter lobe (cos^50 falls to a half at 9.5 deg).
inline constexpr int kVisRays = 4096;

// kVisBytesPerProbe bytes per position, in the order given: the first static or terrain surface
// along kVisRays directions of a Fibonacci sphere (vegetation and dynamic objects are passed
// through: they move or let light through), filtered into the map's texels. `positions` in the
// geometry's local frame. Adds the rays cast to `rays`. Deterministic.
std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, uint64_t& rays);

}  // namespace drtv::baker
