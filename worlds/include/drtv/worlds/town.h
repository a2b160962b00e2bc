// drtv/worlds/town.h — a procedural town of multi-storey buildings, deterministic from a seed.
//
// The hard case for probe lighting (issue 35): storeys 2.8-3.6 m apart, rooms behind thin walls,
// open windows and doors, corridors, stairwells, courtyards and arcades, some rooms lit by lamps,
// on a gently rolling terrain. A square `size_m` wide centred on the origin is cut by a street
// grid every `block_m` metres; each block is, by a seeded draw, a courtyard block (four wings
// round a yard, a gateway through the front wing's ground floor), a pair of parallel slab
// buildings, one free-standing building, or an open square. Every building is a long block of
// 2-8 storeys (`min_storeys` .. `max_storeys`), 10-14 m deep:
//  - a plinth from below its lowest ground corner to the ground floor; a 0.25 m slab between
//    storeys and a roof slab; 0.3 m facades with a window (1.4 x 1.4 m, sill 0.9 m) in every
//    ~4 m bay and a street door in the middle of the ground floor;
//  - a 2 m corridor along the long axis between 0.15 m walls, rooms of one or two bays on both
//    sides with a door each, 0.15 m partitions between rooms;
//  - a stairwell in the first bay: a hole through every slab above the ground and a flight (a
//    sloped slab) from each floor to the next;
//  - where drawn (`arcade_fraction`), an arcade: the street side of the ground floor is pillars,
//    its rooms set back 2.5 m behind them under the first floor's slab, open to the street;
//  - where drawn (`lit_room_fraction`), a lamp in a room: a point light 0.4 m under its ceiling.
// Buildings are static geometry, one mesh per building and material (facade, slabs, inner
// walls), in world coordinates; the terrain is class terrain. Random numbers are keyed by (seed,
// block, field): the same options give the same World on every machine and thread count.
#pragma once

#include <cstdint>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

struct TownOptions {
  double size_m = 1000.0;             // side of the square, metres; [64, 8192]
  uint64_t seed = 1;                  // every random choice derives from it
  double block_m = 72.0;              // street grid period, metres; [40, 400]
  double street_m = 12.0;             // street width, metres; [4, block_m - 28]
  uint32_t min_storeys = 2;           // [1, 16]
  uint32_t max_storeys = 8;           // [min_storeys, 16]
  double min_storey_m = 2.8;          // floor-to-floor height, drawn per block; [2.5, 4]
  double max_storey_m = 3.6;          // [min_storey_m, 4]
  double courtyard_fraction = 0.45;   // share of blocks that are courtyard blocks
  double pair_fraction = 0.3;         // share that are two parallel slab buildings
  double square_fraction = 0.1;       // share left open (a square); the rest: one building
  double arcade_fraction = 0.3;       // share of street-facing buildings with an arcade
  double lit_room_fraction = 0.05;    // share of rooms with a lamp; [0, 1]
  float lamp_intensity = 4.0f;        // a lamp's radiant intensity, W/sr (warm white); (0, 1e4]
  double terrain_height_m = 6.0;      // hills' height over the square; [0, 100]
  double grid_spacing_m = 4.0;        // terrain vertex spacing; [1, 64]
};

// Generates the town. Fails (message "town: key '<field>': ...") when an option is out of range,
// not finite, or the fractions sum past 1. 1 km² with the defaults: ~300 buildings, ~1,700
// storeys, ~2.3 M triangles, about 0.5 s in Release.
Result<World> generateTown(const TownOptions& options);

}  // namespace drtv::worlds
