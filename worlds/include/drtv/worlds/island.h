// drtv/worlds/island.h — a procedural tropical island, deterministic from a seed.
//
// Terrain: a square heightfield sqrt(size_km2) km wide centred on the origin, fBm value noise
// shaped by a noisy radial falloff so that the land sinks below sea level (z = 0) before the
// edges; the sea surface itself is not geometry. On land: clusters of trees (a trunk box and a
// crown ellipsoid, class vegetation, all trees sharing two meshes), rocks (static), low walls
// (static boxes) and buildings (static boxes; a share of them hollow, with a door gap, a roof
// and an InteriorVolume whose designated probe sits in the middle of the room).
// Random numbers are keyed by (seed, object kind, index): the same options give an identical
// World on every machine and thread count.
#pragma once

#include <cstdint>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

struct IslandOptions {
  double size_km2 = 1.0;            // area of the square generated (land and sea), km^2; > 0, <= 256
  uint64_t seed = 1;                // every random choice derives from it
  double grid_spacing_m = 4.0;      // terrain vertex spacing, metres; 2 (sharp) .. 16 (coarse)
  double max_height_m = 60.0;       // tallest hills above sea level, metres
  double trees_per_km2 = 4000.0;    // trees per km^2 of the whole square (grouped in clusters)
  double trees_per_cluster = 12.0;  // mean cluster size
  double rocks_per_km2 = 600.0;     // rocks per km^2
  double buildings_per_km2 = 40.0;  // buildings per km^2
  double walls_per_km2 = 60.0;      // free-standing walls per km^2
  double interior_fraction = 0.5;   // share of buildings that are hollow with an interior, [0, 1]
};

// Generates the island. Fails (message "island: key '<field>': ...") when an option is out of
// range or not finite. 16 km^2 with the defaults: about 2 M terrain triangles, ~1 s in Release.
Result<World> generateIsland(const IslandOptions& options);

}  // namespace drtv::worlds
