// visibility_bake.h — the depth-moment maps of covered probes (drtv/formats/visibility.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {

// Rays per probe (BakeSettings::visibility_rays): 1,024 by default, about 7 within each texel's
// filter lobe (cos^50 falls to a half at 9.5 deg); the builds before 2026-12-06's second session
// cast 4,096 (28 a lobe), which read the same to 0.1 % in `drtv accuracy` at 4x the rays.
inline constexpr int kVisRaysDefault = 1024;
inline constexpr int kVisRaysBefore = 4096;
inline constexpr int kVisRaysMin = 64, kVisRaysMax = 16384;

// kVisBytesPerProbe bytes per position, in the order given: the first static or terrain surface
// along `ray_count` (in [kVisRaysMin, kVisRaysMax]) directions of a Fibonacci sphere (vegetation
// and dynamic objects are passed through: they move or let light through), filtered into the
// map's texels. `positions` in the geometry's local frame. Adds the rays cast to `rays`.
// Deterministic; thread-safe.
//
// With `openings`, a ray that leaves the covered air before it meets a surface ends where it
// leaves it: at the first point along it, sampled every kVisOpeningStepM, with no static surface
// straight above it (through a window, a door or past the eaves into the open). A covered probe
// then does not "see" the street, the yard or the terrace outside its room through the openings:
// the fine level blends it into points under a roof only, and the points outside read the far
// field's open probes (index_grid.h, same_side). What counts as covered is the highest static
// surface over a kVisOpeningCellM lattice (one ray down per cell the rays reach). A probe that
// stands in the open itself (relocated sideways past the eaves) keeps its rays whole.
inline constexpr float kVisOpeningStepM = 0.25f, kVisOpeningCellM = 0.5f;
std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, int ray_count, bool openings, uint64_t& rays);

}  // namespace drtv::baker
