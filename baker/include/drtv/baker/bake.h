// drtv/baker/bake.h — World -> sectorised archive: the `drtv bake` library entry point.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 15-24.
//
// Two passes (each sector is baked alone from the geometry within a halo around it, so sectors
// can be baked in any order, by any process, and resumed):
//  1. Placement (placement.h), only when LPRT is baked: a sector's LPRT sources are its own and
//     its 8 neighbours' probes, named by (neighbour, probe index), so every sector's placement
//     must be known before any sector's transfer. Each sector is placed once, in its own scene
//     (placeSector), by whichever process needs it; the result is a pure function of the world,
//     the key and the settings, and is appended to that process's placement journal
//     "<archive>.sectors/placement-<k>-of-<N>.log" (resumed like the sectors). Sources therefore
//     name exactly the probes their neighbours bake: there is nothing to reconcile at packing.
//     Without LPRT nothing depends on a neighbour, and each sector places its probes inside its
//     own task on the scene it bakes with (no second gather).
//  2. Per sector: gather (world_geometry.h) -> Embree scene (ray_scene.h) -> its placement ->
//     LPRT sources (the placements of pass 1) -> transfer (transfer.h) -> index grid
//     (index_grid.h) -> ground map -> encoded sector appended as one checked record to its shard's
//     journal, "<archive>.sectors/sectors-<k>-of-<N>.log".
// Then the journals' sectors are packed, in key order, into the archive with a Manifest holding the
// bounds, the effects baked, the bake settings, the sky, the lights and the interiors.
//
// Halo: 64 m (one sector) of geometry around the sector occludes and bounces; rays leaving it
// reach the sky. With LPRT it is 80 m: the sources sit up to a sector away, and their light must
// be occluded and bounced by what lies around them too (placement itself looks 16 m around).
//
// Determinism: the archive depends only on the world, the quality and the seed — not on the
// thread count, the shard split or whether the bake was resumed (tests say so).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "drtv/baker/buildings.h"
#include "drtv/baker/shard.h"
#include "drtv/baker/index_grid.h"
#include "drtv/baker/placement.h"
#include "drtv/baker/rooms.h"
#include "drtv/baker/sector_costs.h"
#include "drtv/baker/transfer.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/worlds/world.h"

namespace drtv::baker {

enum class Quality { kDraft, kDefault, kHigh };
// "draft", "default", "high".
const char* qualityName(Quality q);
std::optional<Quality> parseQuality(std::string_view name);

// Everything that shapes the baked bytes. Presets (docs/baker.md has their measured cost):
//   draft:   32 rays/basis, 12 surfel rays, 3 m cells, 2 bounces, 4 grid candidates
//   default: 128 rays/basis, 24 surfel rays, 2 m cells, 2 bounces, 8 grid candidates
//   high:    512 rays/basis, 64 surfel rays, 1 m cells, 3 bounces, 16 grid candidates
struct BakeSettings {
  Quality quality = Quality::kDefault;
  PlacementSettings placement;
  TransferSettings transfer;
  IndexGridSettings grid;
  RoomSettings rooms;          // closed rooms found and given interiors (rooms.h)
  double halo_m = 64.0;        // geometry gathered around a sector without LPRT (metres)
  double lprt_halo_m = 80.0;   // with LPRT (see above)
  int zstd_level = 3;          // archive compression (zstd's default; ratio ~2 at every level)
  // Probes under roofs flagged kProbeCovered and given visibility maps (visibility.h), which the
  // runtime's fine level reads (issue 35). false bakes the archives of the builds before it.
  bool covered_visibility = true;
  // Rays a covered probe's visibility map is filtered from (visibility_bake.h): 1,024; the builds
  // before 2026-12-06's second session cast 4,096 (`drtv bake --visibility-rays 4096`).
  int visibility_rays = 1024;
  // The visibility maps end where a ray leaves the covered air (visibility_bake.h, openings): a
  // covered probe is not blended into the street or the yard it sees through a window. false:
  // the maps of the builds before 2026-12-07.
  bool visibility_openings = true;
  // With LPRT: a source probe where each still light under static geometry stands (placement.h,
  // step 7), which the runtime gives that light whole (issue 35). false bakes the archives of the
  // builds before it.
  bool light_sources = true;

  static BakeSettings forQuality(Quality q, uint64_t seed = 1);
  // (key, value) pairs stored in the manifest and used in the resume fingerprint.
  std::vector<std::pair<std::string, std::string>> describe() const;
};

// Which effects a bake of `world` produces: the world's mask minus what it has no content for
// (local lights without point lights, interiors without volumes). `skipped` receives one line per
// effect not baked, with the reason.
uint32_t effectsToBake(const worlds::World& world, std::vector<std::string>* skipped);

// Per-sector figures for the report. Ray counts are exact; times are wall seconds of the stage
// within the sector's task (inner stages run on all threads).
struct SectorStats {
  SectorKey key;
  size_t probes = 0;
  size_t triangles = 0;                 // gathered, halo included
  size_t lprt_sources = 0;
  size_t bytes = 0;                     // encoded sector
  size_t bytes_without_lprt = 0;        // the same sector without its LPRT block
  PlacementStats placement;
  TransferStats transfer;
  IndexGridStats grid;
  uint64_t other_rays = 0;              // ground map and the covered probes' visibility maps
  double gather_s = 0, build_s = 0, placement_s = 0, transfer_s = 0, grid_s = 0, total_s = 0;
  double visibility_s = 0;              // the covered probes' visibility maps (visibility.h)
  bool resumed = false;                 // read back from a sector file of an earlier run
  uint64_t rays() const {
    return placement.rays + transfer.probe_rays + transfer.surfel_rays + transfer.lprt_rays + transfer.sun_rays + grid.rays + other_rays;
  }
};

struct BakeOptions {
  Quality quality = Quality::kDefault;
  uint64_t seed = 1;                     // keys every random number
  int threads = 0;                       // worker threads; 0 = all hardware threads
  std::optional<raytrace::SectorRange> sectors;    // bake only these sector keys (inclusive)
  int shard_index = 0, shard_count = 1;  // bake sectors i with i % count == index; no archive
                                         // unless count == 1 (then merge with merge_only)
  bool merge_only = false;               // bake nothing: pack the sectors the shards journaled
  bool fresh = false;                    // discard sector journals of a different bake
  bool keep_sector_files = false;        // keep "<archive>.sectors/" after packing
  std::optional<BakeSettings> settings;  // overrides the quality preset (tests)
  // The directional representation (representation.h); unset = the world's, else sh-l1.
  std::optional<Representation> representation;
  // Probe clearance (placement.h PlacementSettings::clearance_m); unset = the preset's. 0 is the
  // talk's placement, and bakes the archives of every build before the clearance, byte for byte.
  std::optional<double> clearance_m;
  // Index cells inside geometry (index_grid.h IndexGridSettings::inside_from_neighbours); unset =
  // the preset's (true). false, with clearance 0, bakes the archives of every earlier build.
  std::optional<bool> inside_from_neighbours;
  // Index cells name probes on their own side of the sky line (IndexGridSettings::same_side);
  // unset = the preset's (true). false bakes the archives of the builds before it.
  std::optional<bool> grid_same_side;
  // The room search (rooms.h RoomSettings::enabled); unset = the preset's (true). false bakes the
  // archives of the builds before it, byte for byte.
  std::optional<bool> find_rooms;
  // Surface cache cells split by the walls that cross them (transfer.h TransferSettings::
  // cell_sides); unset = the preset's (true). false bakes the archives of the builds before it.
  std::optional<bool> cell_sides;
  // BakeSettings::covered_visibility; unset = the preset's (true).
  std::optional<bool> covered_visibility;
  // BakeSettings::visibility_rays; unset = the preset's (1,024).
  std::optional<int> visibility_rays;
  // BakeSettings::light_sources; unset = the preset's (true).
  std::optional<bool> light_sources;
  // PlacementSettings::enclosed_column_spacing_m and enclosed_min_horizontal_m both; 0 = the
  // covered values (the placement before 2026-12-06); unset = the preset's (2 m).
  std::optional<double> enclosed_spacing_m;
  // PlacementSettings::covered_stack_m; 0 = one probe per floor under roofs (the bytes of the
  // builds before 2026-12-07's sixth session); unset = the preset's (3 m).
  std::optional<double> covered_stack_m;
  // TransferSettings::sweeps; 0 = bounces - 1 (the bytes of the builds before 2026-12-07); unset =
  // the preset's (kPresetSweeps).
  std::optional<int> sweeps;
  // Measured per-sector times of an earlier bake (sector_costs.h, `drtv bake --costs`): the
  // shards split by them. Every shard and the merge of a bake must be given the same (or none).
  std::optional<MeasuredCosts> costs;
  // Called after each sector with (done, total), from one thread at a time. May be empty.
  std::function<void(size_t, size_t)> progress;
};

// The probes one sector places, in its own frame (x, y from its min corner), in the order its
// record stores them, with the figures of its placement.
struct SectorPlacement {
  std::vector<PlacedProbe> probes;
  PlacementStats stats;
  double seconds = 0;  // gather, scene build and placement, wall
};
using SectorPlacements = std::map<SectorKey, SectorPlacement>;

// The placement pass of a bake with LPRT (see the top of this file).
struct PlacementPass {
  size_t sectors = 0;          // placements this bake used (its sectors and their neighbours)
  size_t resumed = 0;          // of which read back from placement journals
  size_t outside = 0;          // of which not baked by this process (neighbours, other shards)
  uint64_t outside_rays = 0;   // rays cast placing those (the bake's own sectors count theirs)
  double seconds = 0;          // wall time of the pass
};

struct BakeReport {
  std::string world;                     // name or file
  std::filesystem::path archive;
  BakeSettings settings;
  int threads = 0;
  std::string shard;                     // "k/N", or "" for a whole bake
  std::string geometry_fingerprint;      // the world's geometry (16 hex digits): what --costs matches
  std::string split = "estimated";       // how the sectors were split among shards (SectorCosts::split)
  uint32_t effects_asked = 0, effects_baked = 0;
  std::vector<std::string> effects_skipped;  // "local_lights: the world has no point lights"
  std::vector<std::string> notes;        // geometry skips and repairs
  std::vector<std::string> world_notes;  // the loaders' (World::notes): materials, emission, skips
  worlds::MaterialCounts materials;      // World::materials
  std::vector<SectorStats> sectors;      // every sector baked or resumed, in key order
  size_t sectors_empty = 0;              // sectors with no probe (not written to the archive)
  size_t triangles = 0;                  // contributing triangles in the world
  PlacementPass placement_pass;          // empty without LPRT
  RoomStats rooms;                       // the room search (rooms.h); its rooms.rooms are the
                                         // manifest's interiors after the artist's ("room N")
  // The buildings of the packed archive (buildings.h), the most probes first; empty for a shard
  // (the merge that packs reports them).
  std::vector<BuildingStats> buildings;
  double geometry_s = 0, rooms_s = 0, bake_s = 0, pack_s = 0, wall_s = 0;
  // The process's peak resident memory when bake() returned (peakResidentBytes, memory_limit.h):
  // everything it held since it started, the world's load included. 0 where the system does not
  // say, and for bakeInMemory.
  uint64_t peak_rss_bytes = 0;
  // A merge's: the status of every shard of this bake (its last run's time, peak memory and host),
  // ordered by (count, index); empty for a whole bake or a shard.
  std::vector<ShardStatus> shards;
  bool packed = false;                   // the archive was written (false for a shard)
};

// What is wrong with bake settings (they can come from a library caller), as an error; nothing
// when they are sound. The bounds keep
// every loop and allocation they size sane: at most 1024 columns per sector side, 1 << 16 rays.
Result<void> validateSettings(const BakeSettings& settings);

// The manifest of a bake of `world` (bounds, sector size, effects baked, settings and the world's
// name, sky, lights and interiors): what bake() packs and bakeInMemory() returns.
Manifest manifestFor(const raytrace::WorldGeometry& geometry, const worlds::World& world, const std::string& world_name,
                     const BakeSettings& settings, uint32_t effects);

// The world a bake of the sectors in `range` sees: `world` itself, or, when settings.rooms is
// enabled, the world asks for interiors (or derives its effects) and findRooms() finds closed
// rooms there, a copy in `storage` with those rooms appended to its interiors (after the
// artist's, whose indices stay) and, for derived effects, the interiors effect added.
// `geometry` is built from `world` for `range` with a halo of at least settings.rooms.max_extent_m;
// bake() and bakeInMemory() pass the whole world, whatever sectors they bake, so that partial
// bakes and shards find the same rooms.
// Errors: findRooms' (a sector's scene cannot be built).
// `world` with `interiors` in place of its own, in `storage` (the interiors effect added when
// its effects are derived), or `world` itself when they are its own: what worldWithRooms makes
// and what a later pass over the same bake (bakeCube) needs again from the bake's manifest.
const worlds::World& worldWithInteriors(const worlds::World& world, const std::vector<InteriorVolume>& interiors,
                                        std::optional<worlds::World>& storage);

Result<const worlds::World*> worldWithRooms(const worlds::World& world, const raytrace::WorldGeometry& geometry,
                                           const raytrace::SectorRange& range, const BakeSettings& settings,
                                           std::optional<worlds::World>& storage, RoomStats* stats = nullptr);

// The halo of geometry a sector is baked with: lprt_halo_m when local lights are baked (LPRT
// sources sit in the neighbours), else halo_m.
double haloFor(const BakeSettings& settings, uint32_t effects);

// The sectors of `range` in the order a bake numbers them (x, then y).
std::vector<SectorKey> bakeKeys(const raytrace::SectorRange& range);

// Places the probes of sector `key` in its own scene (the gather with haloFor's halo): what the
// sector bakes and what its neighbours' LPRT sources name. Deterministic: the same world, key and
// settings give the same bits in any process. Thread-safe; uses TBB. Errors: the scene cannot be
// built (names the sector).
Result<SectorPlacement> placeSector(const raytrace::WorldGeometry& geometry, const worlds::World& world, SectorKey key,
                                    const BakeSettings& settings, uint32_t effects);

// The sectors whose placement a bake of `keys` needs before its transfer: with LPRT the keys and
// their 8 neighbours (in key order, each once), without it none.
std::vector<SectorKey> placementKeys(std::span<const SectorKey> keys, uint32_t effects);

// placeSector for every key, in parallel, into a map. Errors: the first sector's, in key order.
Result<SectorPlacements> placeSectors(const raytrace::WorldGeometry& geometry, const worlds::World& world,
                                      std::span<const SectorKey> keys, const BakeSettings& settings, uint32_t effects);

// Bakes one sector in memory (no files). `effects` from effectsToBake. `placements` must hold the
// sector's 8 neighbours when LPRT is baked (placementKeys; a missing one is a bug and aborts); the
// sector's own placement is taken from it when present and placed here otherwise (the same bits).
// Thread-safe; uses TBB.
Result<Sector> bakeSector(const raytrace::WorldGeometry& geometry, const worlds::World& world, SectorKey key,
                          const BakeSettings& settings, uint32_t effects, const SectorPlacements& placements,
                          SectorStats& stats);

// The whole bake (see the top of this file). `world_name` prefixes error messages. Writes the
// archive at `archive` (unless a shard), "<archive>.sectors/" while it runs, and nothing else:
// reports are written by writeReports. Errors: bad geometry (world_geometry.h), unwritable
// files, a sector directory from a different bake (unless fresh), missing sectors on merge.
Result<BakeReport> bake(const worlds::World& world, const std::string& world_name, const std::filesystem::path& archive,
                        const BakeOptions& options);

// Writes the report for people (Markdown) and programs (JSON): probes per sector (min/mean/max),
// invalid probes, bytes per sector with and without LPRT, rays and rays/s, time per stage,
// effects baked and skipped.
Result<void> writeReports(const BakeReport& report, const std::filesystem::path& json_path,
                          const std::filesystem::path& markdown_path);

// "<archive>.sectors" — where the sector journals live while a bake runs.
std::filesystem::path sectorDirectory(const std::filesystem::path& archive);

// A bake held in memory: what `drtv bake` would write, without files.
struct InMemoryBake {
  Manifest manifest;             // bounds, effects, settings, sky, lights, interiors (sector list empty)
  std::vector<Sector> sectors;   // sectors with at least one probe, in key order
  std::vector<SectorStats> stats;  // per sector baked (empty ones included)
  double bake_s = 0;             // wall seconds (geometry excluded)
  size_t probes = 0;
  uint64_t rays = 0;
  size_t bytes = 0;              // sum of encodedSectorBytes of `sectors`
};

// Bakes the sectors of `world` in `sectors` (default: all its sectors) with `settings` and the
// effects effectsToBake gives, on `threads` TBB threads (0 = all). Deterministic like bake().
// Errors: those of bake() (bad lighting, geometry), an empty selection.
Result<InMemoryBake> bakeInMemory(const worlds::World& world, const std::string& where, const BakeSettings& settings,
                                  std::optional<raytrace::SectorRange> sectors = std::nullopt, int threads = 0);

}  // namespace drtv::baker
