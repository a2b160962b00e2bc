// drtv/baker/sector_costs.h — what each sector of a bake costs: the shards' split (shard.h
// shardOwners) and the farm's predictions (`drtv farm plan`) follow it. Estimated from the
// triangles a sector gathers, or measured by an earlier bake of the world (issue 36).
//
// Estimated: 1 + the triangles the sector gathers within its halo (WorldGeometry::gatherEstimate).
// A sector's bake time follows it over the island (correlation 0.96-0.97 over its 256 sectors),
// but not where the time goes to something the triangles do not count: LPRT near local lights
// (65 % of the lit island's summed sector time, up to 0.2 s a sector near a lamp), the 2 m lattice
// of rooms, visibility maps.
//
// Measured: each sector's `total_s` in an earlier bake's report (bake-report.json, `per_sector`:
// a draft bake, last night's bake, or a farm bake's merge, whose report holds every shard's
// sectors because the journals keep each sector's time), in microseconds. A sector the report
// lacks (new geometry, an empty sector it skipped, a time of 0) costs its estimate times the
// report's seconds per estimated unit, fitted over the sectors it measured:
//   seconds_per_unit = sum total_s / sum (1 + triangles gathered).
// Times are used sector by sector only when the report baked this world's geometry (its
// `geometry_fingerprint`, raytrace::WorldGeometry::fingerprint); for any other world (a
// projection of a larger one) only the fitted rate is, and the split stays the estimated one.
//
// A sector's `total_s` is its wall time within its task, while the bake ran `threads` sectors at
// once on as many threads: on a machine with a core per thread it is about that sector's CPU time,
// and a shard with C cores takes about the sum of its sectors' times / C (`drtv farm plan`).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"

namespace drtv::raytrace {
class WorldGeometry;
}

namespace drtv::baker {

// An earlier bake's per-sector times, as its report gives them.
struct MeasuredCosts {
  std::string file;                     // the report read
  std::string geometry;                 // its world's geometry fingerprint (16 hex digits)
  std::string world;                    // its world's name or file (for messages)
  int threads = 0;                      // the threads it baked with
  std::map<SectorKey, double> seconds;  // sectors with a time > 0
  double seconds_per_unit = 0;          // fitted (above), > 0
  std::string digest;                   // 16 hex digits of XXH3 over (key, seconds): names the split
  // The memory it measured (not part of the digest), 0 where the report has none (older builds):
  uint64_t peak_bytes = 0;              // its process's peak resident memory (memory.peak_resident_bytes)
  uint64_t shard_peak_bytes = 0;        // a merge's: the most any of its shards held (shard_balance)
  int shards = 0;                       // a merge's: how many shards it listed
};

// Reads a bake report's per-sector times. Errors (bad input), naming the file: unreadable, not a
// bake report (no `per_sector` array of sectors with ix, iy, triangles and total_s), a time that
// is negative, above 1e9 s or not finite, a sector listed twice, no sector with a time above 0,
// no geometry fingerprint (a report of a build before it; bake again).
Result<MeasuredCosts> readMeasuredCosts(const std::filesystem::path& report);

// What each sector of a bake costs.
struct SectorCosts {
  std::vector<uint64_t> units;   // per key, in shardOwners' units
  // What every shard of a bake must agree on to split alike: "estimated", or "measured <digest>"
  // (the report's times, sector by sector). ShardStatus::split; the merge refuses a mix.
  std::string split = "estimated";
  double seconds_per_unit = 0;   // a sector's predicted time = units x this; 0 without a report
  size_t measured = 0;           // keys that have a time of their own from the report
};

// The cost of each of `keys` (bakeKeys' order) baked with `halo_m` (haloFor): estimated, or
// measured by `measured` when it is given (above). Deterministic: every process of a bake given
// the same world, keys and report computes the same units.
SectorCosts sectorCosts(const raytrace::WorldGeometry& geometry, std::span<const SectorKey> keys, double halo_m,
                        const MeasuredCosts* measured = nullptr);
// The same as measured by `measured`, from the estimate sectorCosts gives without it (its units
// are the triangles'), for a world whose geometry has `geometry_fingerprint`
// (WorldGeometry::fingerprint): to have both without gathering twice.
SectorCosts measuredCosts(SectorCosts estimated, std::span<const SectorKey> keys, uint64_t geometry_fingerprint,
                          const MeasuredCosts& measured);

}  // namespace drtv::baker
