// drtv/baker/rooms.h — closed rooms found at bake time, given the talk's interior treatment
// without an artist (issue 16; talk [1] slides 55-56).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
// Far Cry 3's artists place a box inside each problem building and pick a probe for it; every
// pixel inside is shaded with that probe instead of the volume, whose 4 m cells and 2 m texels
// straddle the walls and carry the sky's light in [1, slide 55]. A world written by a user has no
// such boxes. findRooms() finds the closed rooms of the static geometry and makes one interior
// volume for each, which the bake then treats exactly as an artist's (designated probe, manifest,
// runtime blend).
//
// The rule (deterministic, per sector, independent of threads and of other sectors):
//  1. Seeds: vertical rays on a `seed_spacing_m` lattice over the sector, cast down through every
//     terrain and static surface (vegetation takes no part: leaves make no room). Every gap of at
//     least `min_height_m` between a surface met from below or a double-sided one (a ceiling) and
//     the next surface down (a floor) is covered air; its seed stands `seed_height_m` over the floor.
//     The gap from the sky to the first surface is open air and has no seed.
//  2. Enclosure: `test_rays` rays in all directions (a Fibonacci sphere), `max_extent_m` long,
//     from the seed. A seed is in a room when at most `max_open_fraction` of them escape (a window
//     or a door, not the open side of a shed or a balcony's front) and at most a quarter hit a
//     surface from behind its winding (a seed inside a solid, one-sided or double-sided: a room's
//     walls face into it).
//  3. The room's box: rays along the six axes from the seed, then again from the centre of what
//     they found (a seed beside a pillar or in a corner finds the room's middle). Every axis ray
//     must hit within `max_extent_m`; the box is at least `min_width_m` wide, `min_height_m` tall,
//     its centre passes the enclosure test too, and each face is a wall: rays from the centre to a
//     5 x 5 grid over the face end at it, all but a fifth (a window, a door; not a block standing
//     in a larger open space, whose face the axis rays found; nor a room turned off the axes, even by
//     3 degrees, whose walls cross the faces). The designated probe is the centre.
//  4. The box is grown through each wall by half the wall's thickness (at most `wall_margin_m`;
//     the thickness is where the axis ray leaves the wall), and the interior blend is that margin:
//     the room's own surfaces read the designated probe whole, the wall's outer face none of it
//     (the talk blurs its screen-space mask instead; a box has only its faces).
//  5. A seed inside a box already found in the sector is skipped. Over the world, boxes are taken
//     in sector order (x, then y) and seed order; a box that overlaps an artist's interior volume
//     (artists win) or a box taken before is dropped, so a room seen from two sectors is one room.
//
// Limits, by design: an axis-aligned box per room (a room turned off the axes is left to the volume,
// since InteriorVolume is a world-axis box); rooms wider than
// `max_extent_m` (halls) and rooms open by more than `max_open_fraction` are left to the volume.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {

struct RoomSettings {
  bool enabled = true;             // false: only the artist's interiors (`drtv bake --rooms off`)
  double seed_spacing_m = 2.0;     // lattice of the seed columns (metres)
  double seed_height_m = 1.2;      // a seed's height over its floor, at most half the gap (metres)
  double min_height_m = 1.8;       // least floor-to-ceiling height of a room (metres)
  double min_width_m = 1.5;        // least width of a room along x and y (metres)
  double max_extent_m = 24.0;      // longest ray: a room's widest span (metres; <= the bake's halo)
  int test_rays = 64;              // enclosure test rays per seed
  double max_open_fraction = 0.05; // share of the test rays that may escape (windows, a door)
  double wall_margin_m = 0.25;     // most the box grows through a wall (metres)
};

// What the search did, for the bake report.
struct RoomStats {
  size_t seeds = 0;          // covered-air seeds tested
  size_t enclosed = 0;       // seeds that passed the enclosure test
  size_t rooms = 0;          // boxes kept
  size_t dropped_artist = 0; // boxes dropped for overlapping an artist's interior
  size_t dropped_overlap = 0;  // boxes dropped for overlapping a box kept before (the same room)
  size_t rays = 0;           // rays cast
};

// The closed rooms of `geometry` in the sectors of `range`, as interior volumes named "room N"
// (1-based, in the order kept), none overlapping one of `artist` or another. `geometry` must be
// binned for `range` with a halo of at least settings.max_extent_m (a bug otherwise, checked by
// gather). Deterministic: the same geometry, range and settings give the same rooms on any number
// of threads. Thread-safe; uses TBB over sectors. Errors: a sector's scene cannot be built.
Result<std::vector<InteriorVolume>> findRooms(const raytrace::WorldGeometry& geometry, const raytrace::SectorRange& range,
                                              const std::vector<InteriorVolume>& artist, const RoomSettings& settings,
                                              RoomStats* stats = nullptr);

// What is wrong with room settings, as an error (nothing when they are sound).
Result<void> validateRoomSettings(const RoomSettings& settings);

}  // namespace drtv::baker
