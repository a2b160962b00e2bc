// island_detail.h (private) — the island generator with its heightfield, for the JSON loader
// (vegetation scattered over an island needs the ground height).
#pragma once

#include "drtv/worlds/island.h"
#include "terrain.h"

namespace drtv::worlds {

// As generateIsland(); also returns the terrain heightfield in world coordinates when
// `heightfield` is not null.
Result<World> generateIslandWithHeightfield(const IslandOptions& options, Heightfield* heightfield);

}  // namespace drtv::worlds
