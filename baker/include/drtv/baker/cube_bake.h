// drtv/baker/cube_bake.h — the ambient cube's transfer (transfer.h, "The ambient cube") for the
// probes of sectors a drtv bake already placed: the measurement of issue 13 ("The lighting model
// against physics"), eval/techniques/ambient_cube. Held in memory only: no archive format stores
// it (docs/accuracy.md, "Directional representations (issue 13)").
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 18-24.
//  [2] McTaggart, "Half-Life 2 / Valve Source Shading", GDC 2004 (the ambient cube: six axis
//      colours shaded with the squared normal components).
//
// Each sector is gathered and its scene built exactly as bakeSector does (the same halo, the
// same effects), and bakeTransfer runs on the probe positions its record holds, with the same
// transfer settings and seed: the rays, the surface cache and the per-surfel sun and LPRT values
// are the drtv bake's; only the gather to the probes is the cube's (six lobes instead of the
// four bases or the band-1 SH).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "drtv/baker/bake.h"
#include "drtv/baker/transfer.h"

namespace drtv::baker {

struct CubeSector {
  SectorKey key;
  CubeTransfer transfer;                    // per probe of the sector, in record order
  std::vector<glm::vec3> sun_directions;    // the samples transfer.sun holds (sunSamples)
};

struct CubeBake {
  std::vector<CubeSector> sectors;  // one per given sector, in the same order
  double bake_s = 0;                // wall seconds (geometry and placement of LPRT sources included)
  uint64_t rays = 0;                // every ray cast
};

// The ambient cube's transfer for `sectors` (a bake of `world` with `settings`: their records'
// probe positions and LPRT sources). With local lights baked, the neighbours' placements are
// recomputed (placeSectors: the same bits the bake used) to locate the sources; `interiors` are
// those the sectors were baked with (InMemoryBake::manifest.interiors: the world's and the rooms
// bakeInMemory found, rooms.h), or null for the world's own. Deterministic;
// uses `threads` TBB threads (0 = all). Errors: those of bakeInMemory (geometry, lighting).
Result<CubeBake> bakeCube(const worlds::World& world, const std::string& where, const BakeSettings& settings,
                          std::span<const Sector> sectors, int threads = 0,
                          const std::vector<InteriorVolume>* interiors = nullptr);

}  // namespace drtv::baker
