// drtv/baker/index_grid.h — the per-sector 16x16x16 nearest-probe index (talk [1] slide 17),
// with a visibility preference beyond the talk.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
// Each cell holds the one-byte index of a probe. The talk takes the nearest probe; here a cell
// takes the nearest probe that its centre can SEE (an unoccluded segment), among the
// `visibility_candidates` nearest, so that a cell inside a house takes the probe in the room and
// not the one outside the wall 3 m away. Fallbacks: when none of the candidates is visible, the
// nearest visible probe of the whole sector (issue 16: the nearest was often hidden behind a wall
// or inside a building, and its light leaked); when the segment to the nearest probe starts
// inside geometry (its first hit is a back face: the cell centre is under terrain or inside a
// wall), the choice of the first resolved cell above it in its column (the air over the surface,
// on the same side of every wall); then, for those and for cells that see no probe, the choice of
// the nearest cell that resolved (breadth-first over face neighbours). An inside cell took the nearest probe until 2026-12-02: under the ground by a
// closed room that was the room's probe, and the volume's trilinear filter carried its lamp to
// the ground outside the walls (0.095 of the floor's 0.78, tests/reference/data/room.json). A
// sector where no cell resolves keeps the nearest; one without probes keeps 255.
//
// A cell whose centre is inside geometry must never see a probe (it takes the cell above). Rays
// alone did not make sure of it: under room.json's west wall, the segment from the cell centred at
// (-6, 2, -1.5) to the room's probe at (-2, 2, 1.5) leaves the ground exactly through a terrain
// vertex, (-4, 2, 0), and passes under the wall; Embree's AVX2 kernels let it through that vertex
// (its SSE and AVX kernels, and the Xeons' AVX-512, hit the ground's back face), so on AVX2 hosts
// the cell saw the room's probe and the ground outside the wall read 22 % of the room's lamp.
// Cell centres and probes sit on the 2 m terrain lattice often, so such segments are common. So
// a cell that would name a probe inside an interior (the artist's volumes and the rooms found,
// rooms.h) whose box does not hold the cell's centre is asked once more whether its centre is
// inside geometry, by one ray in a fixed oblique direction (no lattice vertex or edge lies on it
// from a lattice point): a back face first means inside. A probe is inside an interior when it is
// the interior's designated probe or when the box holds it: until 2026-12-07's sixth session only
// the designated probe was, and room.json's lattice probe at (2, 2, 1.5), which ties with an
// outside probe as the nearest of the cell under the ground at (2, 6, -1.5), was seen through the
// terrain vertex (2, 4, 0) on AVX2 hosts (the ground outside the north wall read 7 % of the room's
// lamp). And a cell that sees no probe at all is asked the same, and takes the cell above when its
// centre is inside geometry: on AVX2 hosts room.json's segment above went on, after the vertex,
// into the bottom face of the north wall, so the cell saw nothing, and took a neighbour's choice
// breadth-first, which was the cell under the room's floor and the room's probe. Cells that name
// no interior's probe and see one, and worlds without interiors, are as in every build before.
//
// Vertical extent (chooseGridExtent): from 2 m below the lower of the lowest ground sample and
// the lowest probe, to 4 m above the highest probe, split in 16 cells, each at least
// kMinCellHeightM tall; horizontally the cells are 4 m (64 m / 16).
#pragma once

#include <cstdint>
#include <functional>
#include <span>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
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
  // A cell whose centre is inside geometry takes a resolved neighbour cell's choice (true), or
  // the nearest probe (false: the talk's rule, and the archives of every build before
  // 2026-12-02, byte for byte; `drtv bake --inside-cells nearest`).
  bool inside_from_neighbours = true;
  // A cell names a probe on its own side of the sky line when it sees one (issue 35): a cell
  // whose centre has static geometry straight above it (a room, a storey, an arcade) names the
  // nearest visible covered probe (kProbeCovered), a cell under open sky the nearest visible
  // uncovered one; only a cell that sees none of its side takes the rule above, any probe. A
  // cell over a street beside a facade then names a probe of the street, not one in the room
  // behind the facade's window (the town's facades read 0.05 against the path tracer's 0.7).
  // false = the bytes of every build before 2026-12-06's second session (`drtv bake --grid-sides any`).
  bool same_side = true;
};

struct IndexGridStats {
  uint64_t rays = 0;
  size_t cells_nearest = 0;      // took the nearest probe, visible
  size_t cells_farther = 0;      // took a farther probe because the nearer ones were hidden
  size_t cells_inside = 0;       // centre inside geometry: a resolved neighbour's choice
  size_t cells_unseen = 0;       // no probe visible at all: a neighbour cell's choice
  size_t cells_searched = 0;     // no candidate visible, a farther probe beyond them is
  size_t cells_other_side = 0;   // saw no probe of its own side of the sky line: any probe
};

// Chooses z_min_m and cell_height_m (see above). `ground_min_z` may be +inf when unknown.
void chooseGridExtent(std::span<const glm::vec3> probes, float ground_min_z, IndexGrid& grid);

// The interiors whose probes a cell outside them names only after the inside test above, in the
// sector's local frame. `boxes[k]` is interior k + 1's box, a point inside when min <= p < max on every axis (as
// placement.h assigns probes); `probe_interior[i]` is probe i's interior, 0 for none
// (PlacedProbe::interior). Both empty: no interiors, and the grid is the one of every build before.
struct IndexGridInteriors {
  std::span<const raytrace::Box> boxes;
  std::span<const uint16_t> probe_interior;  // empty, or one per probe, each 0..boxes.size()
};

// The sides of the sky line (IndexGridSettings::same_side): which probes are covered, and
// whether a point (sector-relative, as the probes) has static geometry straight above it,
// counting the rays it casts. Empty
// `probe_covered` or no `covered`: every cell and probe on one side, the grid of the builds before.
struct IndexGridSides {
  std::span<const uint8_t> probe_covered;  // empty, or one per probe: 1 = kProbeCovered
  std::function<bool(const glm::vec3&, uint64_t& rays)> covered;
};

// Fills grid.cells for `probes` (sector-relative positions; index = position in the span, at most
// 255) using grid.z_min_m / cell_height_m. Thread-safe; uses TBB inside; deterministic.
// Preconditions (checked): probe_interior is empty or has one entry per probe, none above boxes.size().
void fillIndexGrid(const raytrace::RayScene& scene, std::span<const glm::vec3> probes, const IndexGridSettings& settings,
                   IndexGrid& grid, IndexGridStats& stats, const IndexGridInteriors& interiors = {},
                   const IndexGridSides& sides = {});

}  // namespace drtv::baker
