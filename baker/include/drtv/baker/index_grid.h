// drtv/baker/index_grid.h — the per-sector 16x16x16 nearest-probe index (talk [1] slide 17),
// with a visibility preference beyond the talk.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
// Each cell holds the one-byte index of a probe. The talk takes the nearest probe; here a cell
// takes the nearest probe that its centre can SEE (an unoccluded segment), among the
// `visibility_candidates` nearest, so that a cell inside a house takes the probe in the room and
// not the one outside the wall 3 m away. Fallbacks, in order: when the segment to the nearest
// probe starts inside geometry (its first hit is a back face: the cell centre is under terrain
// or inside a wall) the cell takes the nearest probe — nothing better can be known from there;
// when none of the candidates is visible, the nearest visible probe of the whole sector (issue 16:
// the nearest was often hidden behind a wall or inside a building, and its light leaked); when no
// probe is visible, the choice of the nearest cell that resolved (breadth-first over face
// neighbours). A sector without probes keeps 255.
//
// Vertical extent (chooseGridExtent): from 2 m below the lower of the lowest ground sample and
// the lowest probe, to 4 m above the highest probe, split in 16 cells, each at least
// kMinCellHeightM tall; horizontally the cells are 4 m (64 m / 16).
#pragma once

#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/formats/sector.h"

namespace drtv::baker {

// Cells are never thinner than this: below it the 16 cells would cover less than the height of a
// two-storey building (flat sea sectors otherwise get a 0.4 m grid).
inline constexpr float kMinCellHeightM = 1.f;

struct IndexGridSettings {
  int visibility_candidates = 8;  // nearest probes tried for visibility per cell (1 = the talk)
  // When none of them is visible: try the sector's other probes, nearest first, and give a cell
  // that sees none a neighbour cell's choice (false with 1 candidate = the talk's nearest probe).
  bool search_beyond = true;
};

struct IndexGridStats {
  uint64_t rays = 0;
  size_t cells_nearest = 0;      // took the nearest probe, visible
  size_t cells_farther = 0;      // took a farther probe because the nearer ones were hidden
  size_t cells_inside = 0;       // centre inside geometry: nearest
  size_t cells_unseen = 0;       // no probe visible at all: a neighbour cell's choice
  size_t cells_searched = 0;     // no candidate visible, a farther probe beyond them is
};

// Chooses z_min_m and cell_height_m (see above). `ground_min_z` may be +inf when unknown.
void chooseGridExtent(std::span<const glm::vec3> probes, float ground_min_z, IndexGrid& grid);

// Fills grid.cells for `probes` (sector-relative positions; index = position in the span, at most
// 255) using grid.z_min_m / cell_height_m. Thread-safe; uses TBB inside; deterministic.
void fillIndexGrid(const raytrace::RayScene& scene, std::span<const glm::vec3> probes, const IndexGridSettings& settings,
                   IndexGrid& grid, IndexGridStats& stats);

}  // namespace drtv::baker
