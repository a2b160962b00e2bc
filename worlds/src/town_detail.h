// town_detail.h (private) — the town generator with its heightfield, for the JSON loader
// (vegetation scattered over a town needs the ground height).
#pragma once

#include "drtv/worlds/town.h"
#include "terrain.h"

namespace drtv::worlds {

// As generateTown(); also returns the terrain heightfield in world coordinates when
// `heightfield` is not null.
Result<World> generateTownWithHeightfield(const TownOptions& options, Heightfield* heightfield);

}  // namespace drtv::worlds
