// The bake orchestration: per-sector pipeline, sector files, resumption, shards, packing.
// See bake.h for the overview and references.
#include "drtv/baker/bake.h"
#include "visibility_bake.h"

#include <unistd.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <xxhash.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include "drtv/baker/shard.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/raytrace/sampling.h"
#include "atomic_file.h"
#include "bake_directory.h"
#include "placement_record.h"
#include "sector_journal.h"
#include "sector_stats.h"
#include "static_rays.h"
#include "drtv/baker/stopwatch.h"

namespace drtv::baker {
namespace fs = std::filesystem;
namespace {

using detail::bakeFingerprint;
using detail::claimSectorDirectory;
using detail::decodePlacement;
using detail::encodePlacement;
using detail::fingerprintText;
using detail::missingShards;
using detail::readFile;
using detail::shardsOfThisBake;

using detail::Clock;
using detail::since;

// Ground-map rays start this far above the gathered geometry.
constexpr float kGroundRayMarginM = 10.f;
// Hits stepped through per ground ray (vegetation is passed through to reach the ground).
constexpr int kMaxGroundHits = 128;

// Highest terrain/static surface under (x, y), local frame; NaN if none.
float groundAt(const raytrace::RayScene& scene, const raytrace::SectorGeometry& g, float x, float y, uint64_t& rays) {
  const glm::vec3 origin(x, y, g.z_max + kGroundRayMarginM);
  const float len = g.z_max - g.z_min + 2.f * kGroundRayMarginM;
  const float t = detail::staticHitDistance(scene, g, origin, glm::vec3(0, 0, -1), len, kMaxGroundHits, rays);
  return std::isfinite(t) ? origin.z - t : NAN;
}



std::vector<LocalInterior> localInteriors(const worlds::World& world, SectorKey key, uint32_t effects) {
  std::vector<LocalInterior> out;
  if (!(effects & kEffectInteriors)) return out;
  const glm::dvec3 origin(key.ix * kSectorSizeM, key.iy * kSectorSizeM, 0.0);
  for (size_t i = 0; i < world.interiors.size() && i < 65535; ++i) {
    const InteriorVolume& v = world.interiors[i];
    out.push_back({{glm::vec3(v.min - origin), glm::vec3(v.max - origin)}, glm::vec3(v.probe_position - origin), uint16_t(i + 1)});
  }
  return out;
}

// The baked lights' own LPRT sources in sector `key` (placement.h, step 7): each light that
// stands still (no path, or a path whose keys all keep its position: a flicker) and lies in the
// sector, brightest first (ties in world order), at most kMaxLightSourcesPerSector. Empty without
// LPRT or with BakeSettings::light_sources off. A probe's local position and the light's reach.
struct LightSourceSpot {
  glm::vec3 position;
  float radius_m;
};
std::vector<LightSourceSpot> localLightSources(const worlds::World& world, SectorKey key, const BakeSettings& settings,
                                               uint32_t effects) {
  std::vector<LightSourceSpot> out;
  if (!(effects & kEffectLocalLights) || !settings.light_sources) return out;
  struct Lit {
    size_t i;
    double brightness;
    float radius_m;
  };
  std::vector<Lit> lit;
  for (size_t i = 0; i < world.lights.size(); ++i) {
    const PointLight& l = world.lights[i];
    float radius_m = l.radius_m;
    if (i < world.light_paths.size() && !world.light_paths[i].keys.empty()) {
      bool still = true;
      for (const LightKey& k : world.light_paths[i].keys) {
        still &= k.position == l.position;
        radius_m = std::max(radius_m, k.radius_m);
      }
      if (!still) continue;
    }
    if (SectorKey{int32_t(std::floor(l.position.x / kSectorSizeM)), int32_t(std::floor(l.position.y / kSectorSizeM))} != key) continue;
    lit.push_back({i, double(l.intensity.r) + l.intensity.g + l.intensity.b, radius_m});
  }
  std::stable_sort(lit.begin(), lit.end(), [](const Lit& a, const Lit& b) { return a.brightness > b.brightness; });
  if (lit.size() > size_t(kMaxLightSourcesPerSector)) lit.resize(kMaxLightSourcesPerSector);
  const glm::dvec3 origin(key.ix * kSectorSizeM, key.iy * kSectorSizeM, 0.0);
  for (const Lit& l : lit) out.push_back({glm::vec3(world.lights[l.i].position - origin), l.radius_m});
  return out;
}

std::vector<glm::vec3> positionsOf(std::span<const LightSourceSpot> spots) {
  std::vector<glm::vec3> out;
  for (const LightSourceSpot& s : spots) out.push_back(s.position);
  return out;
}

// `r` and the ring of sectors around it (saturating at the key range's ends).
raytrace::SectorRange grownByOne(raytrace::SectorRange r) {
  constexpr int32_t lo = std::numeric_limits<int32_t>::min(), hi = std::numeric_limits<int32_t>::max();
  return {r.x0 > lo ? r.x0 - 1 : lo, r.x1 < hi ? r.x1 + 1 : hi, r.y0 > lo ? r.y0 - 1 : lo, r.y1 < hi ? r.y1 + 1 : hi};
}

}  // namespace

Manifest manifestFor(const raytrace::WorldGeometry& geometry, const worlds::World& world, const std::string& world_name,
                     const BakeSettings& settings, uint32_t effects) {
  Manifest m;
  m.bounds_min = geometry.boundsMin();
  m.bounds_max = geometry.boundsMax();
  m.sector_size_m = kSectorSizeM;
  m.effects = effects;
  m.settings = settings.describe();
  m.representation = settings.transfer.representation;
  m.settings.emplace_back("world", world.name.empty() ? world_name : world.name);
  m.sky = world.sky;
  m.lights = world.lights;
  m.interiors = world.interiors;
  return m;
}

Result<const worlds::World*> worldWithRooms(const worlds::World& world, const raytrace::WorldGeometry& geometry,
                                           const raytrace::SectorRange& range, const BakeSettings& settings,
                                           std::optional<worlds::World>& storage, RoomStats* stats) {
  if (stats) *stats = RoomStats{};
  const bool asked = world.effects_explicit ? (world.effects & kEffectInteriors) != 0 : true;
  if (!settings.rooms.enabled || !asked || range.empty()) return &world;
  auto rooms = findRooms(geometry, range, world.interiors, settings.rooms, stats);
  if (!rooms) return std::unexpected(rooms.error());
  if (rooms->empty()) return &world;
  // The manifest stores at most 65,535 interiors (probe.h's 16-bit index); the artist's come first.
  std::vector<InteriorVolume> all = world.interiors;
  for (InteriorVolume& r : *rooms) {
    if (all.size() >= 65535) break;
    all.push_back(std::move(r));
  }
  if (stats) stats->rooms = all.size() - world.interiors.size();
  return &worldWithInteriors(world, all, storage);
}

const worlds::World& worldWithInteriors(const worlds::World& world, const std::vector<InteriorVolume>& interiors,
                                        std::optional<worlds::World>& storage) {
  if (interiors.size() == world.interiors.size()) return world;  // rooms only ever add to the artist's
  storage.emplace(world);
  storage->interiors = interiors;
  if (!storage->effects_explicit) storage->effects |= kEffectInteriors;
  return *storage;
}

double haloFor(const BakeSettings& settings, uint32_t effects) {
  return (effects & kEffectLocalLights) ? settings.lprt_halo_m : settings.halo_m;
}

std::vector<SectorKey> bakeKeys(const raytrace::SectorRange& range) {
  std::vector<SectorKey> keys;
  keys.reserve(range.count());
  for (int32_t x = range.x0; !range.empty() && x <= range.x1; ++x) {
    for (int32_t y = range.y0; y <= range.y1; ++y) {
      keys.push_back({x, y});
      if (y == range.y1) break;  // y1 may be INT32_MAX
    }
    if (x == range.x1) break;
  }
  return keys;
}


// The placement settings of a bake: without the fine level (whose covered flags it clears), a
// covered candidate is relocated and kept apart as in the builds before 2026-12-07
// (covered_stays_under, covered_sight), with one probe per floor (covered_stack_m).
namespace {
PlacementSettings placementOf(const BakeSettings& settings) {
  PlacementSettings p = settings.placement;
  p.covered_stays_under = p.covered_stays_under && settings.covered_visibility;
  p.covered_sight = p.covered_sight && settings.covered_visibility;
  p.thin_near_first = p.thin_near_first && settings.covered_visibility;
  if (!settings.covered_visibility) p.covered_stack_m = 0.0;
  return p;
}
}  // namespace

Result<SectorPlacement> placeSector(const raytrace::WorldGeometry& geometry, const worlds::World& world, SectorKey key,
                                    const BakeSettings& settings, uint32_t effects) {
  const auto t0 = Clock::now();
  const raytrace::SectorGeometry g = geometry.gather(key, haloFor(settings, effects));
  auto scene = raytrace::RayScene::build(g.vertices, g.twoSided());
  if (!scene) return std::unexpected(scene.error().context("sector " + toString(key)));
  SectorPlacement out;
  out.probes = placeProbes(*scene, g, {0, 0}, localInteriors(world, key, effects), placementOf(settings), out.stats,
                           positionsOf(localLightSources(world, key, settings, effects)));
  out.seconds = since(t0);
  return out;
}

std::vector<SectorKey> placementKeys(std::span<const SectorKey> keys, uint32_t effects) {
  std::vector<SectorKey> out;
  if (!(effects & kEffectLocalLights)) return out;
  for (const SectorKey k : keys)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) out.push_back({k.ix + dx, k.iy + dy});
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Result<SectorPlacements> placeSectors(const raytrace::WorldGeometry& geometry, const worlds::World& world,
                                      std::span<const SectorKey> keys, const BakeSettings& settings, uint32_t effects) {
  std::vector<std::optional<Result<SectorPlacement>>> placed(keys.size());
  tbb::parallel_for(size_t(0), keys.size(), [&](size_t i) { placed[i] = placeSector(geometry, world, keys[i], settings, effects); });
  SectorPlacements out;
  for (size_t i = 0; i < keys.size(); ++i) {
    if (!*placed[i]) return std::unexpected(placed[i]->error());
    out[keys[i]] = std::move(**placed[i]);
  }
  return out;
}

Result<Sector> bakeSector(const raytrace::WorldGeometry& geometry, const worlds::World& world, SectorKey key,
                          const BakeSettings& settings, uint32_t effects, const SectorPlacements& placements,
                          SectorStats& stats) {
  const auto t_start = Clock::now();
  stats = SectorStats{};
  stats.key = key;
  const bool lprt = (effects & kEffectLocalLights) != 0;
  TransferSettings ts = settings.transfer;
  ts.prt = (effects & (kEffectSunBounce | kEffectSkyBounce)) != 0;
  ts.sky_visibility = (effects & kEffectDirectSky) != 0;

  auto t0 = Clock::now();
  const raytrace::SectorGeometry g = geometry.gather(key, haloFor(settings, effects));
  stats.triangles = g.triangleCount();
  stats.gather_s = since(t0);
  t0 = Clock::now();
  auto scene = raytrace::RayScene::build(g.vertices, g.twoSided());
  if (!scene) return std::unexpected(scene.error().context("sector " + toString(key)));
  stats.build_s = since(t0);

  // The sector's probes: from the placement pass when it ran (the same bits placeSector gives
  // here, since the scene is the same gather), else placed on this scene.
  std::vector<PlacedProbe> placed;
  if (const auto own = placements.find(key); own != placements.end()) {
    placed = own->second.probes;
    stats.placement = own->second.stats;
    stats.placement_s = own->second.seconds;
  } else {
    t0 = Clock::now();
    placed = placeProbes(*scene, g, {0, 0}, localInteriors(world, key, effects), placementOf(settings), stats.placement,
                         positionsOf(localLightSources(world, key, settings, effects)));
    stats.placement_s = since(t0);
  }

  if (!settings.covered_visibility)
    for (PlacedProbe& p : placed) p.flags &= uint16_t(~kProbeCovered);

  Sector sector;
  sector.key = key;
  // Ground map: 8 x 8 samples at 8 m cell centres (also bounds the grid from below).
  float ground_min = INFINITY, ground_max = -INFINITY;
  std::array<float, kGroundDim * kGroundDim> ground{};
  for (int y = 0; y < kGroundDim; ++y)
    for (int x = 0; x < kGroundDim; ++x) {
      const float step = float(kSectorSizeM / kGroundDim);
      const float z = groundAt(*scene, g, (x + 0.5f) * step, (y + 0.5f) * step, stats.other_rays);
      ground[size_t(y * kGroundDim + x)] = z;
      if (std::isfinite(z)) {
        ground_min = std::min(ground_min, z);
        ground_max = std::max(ground_max, z);
      }
    }
  if ((effects & kEffectDistantOcclusion) && std::isfinite(ground_min)) {
    sector.has_ground = true;
    sector.ground_z_min_m = ground_min;
    sector.ground_z_max_m = ground_max;
    const float range = ground_max - ground_min;
    for (size_t i = 0; i < ground.size(); ++i) {
      const float z = std::isfinite(ground[i]) ? ground[i] : ground_min;  // no ground: lowest
      sector.ground[i] = range > 0.f ? quantizeUnorm16((z - ground_min) / range) : 0;
    }
  }
  stats.probes = placed.size();
  if (placed.empty()) {
    stats.total_s = since(t_start);
    return sector;
  }

  // LPRT sources, from this sector's and its 8 neighbours' probes as the placement pass placed
  // them in their own scenes ((dx, dy, i) is the i-th probe of the neighbour's record by
  // construction): first the baked lights' own sources (placement.h, step 7) whose light reaches
  // this sector, nearest to its centre first, at most half the block; then the probes nearest to
  // its centre, for the lights that move (the runtime shares those out, probe_cache.h).
  struct Source {
    LprtSource ref;
    glm::vec3 position;
    float d2;
  };
  std::vector<Source> sources;
  if (lprt) {
    std::vector<Source> at_lights;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const SectorKey nk{key.ix + dx, key.iy + dy};
        const auto it = placements.find(nk);
        DRTV_CHECK(it != placements.end());  // the caller ran the placement pass (placementKeys)
        const std::vector<PlacedProbe>& nb = it->second.probes;
        DRTV_CHECK_LE(nb.size(), size_t(kMaxProbesPerSector));
        const std::vector<LightSourceSpot> spots = localLightSources(world, nk, settings, effects);
        // The neighbour's frame shifted by whole sectors into this one's; z is world z in both.
        const glm::vec3 shift(float(dx * kSectorSizeM), float(dy * kSectorSizeM), 0.f);
        for (size_t i = 0; i < nb.size(); ++i) {
          const glm::vec3 position = nb[i].position + shift;
          const glm::vec2 d = glm::vec2(position) - glm::vec2(float(kSectorSizeM / 2));
          const Source src{{int8_t(dx), int8_t(dy), uint8_t(i)}, position, glm::dot(d, d)};
          if (!(nb[i].flags & kProbeLightSource)) {
            sources.push_back(src);
            continue;
          }
          const auto spot = std::find_if(spots.begin(), spots.end(), [&](const LightSourceSpot& l) { return l.position == nb[i].position; });
          DRTV_CHECK(spot != spots.end());  // placed from the same lights
          // The light's reach against this sector's square.
          const glm::vec2 gap = glm::max(glm::vec2(0.f), glm::max(-glm::vec2(position), glm::vec2(position) - float(kSectorSizeM)));
          if (glm::dot(gap, gap) < spot->radius_m * spot->radius_m) at_lights.push_back(src);
        }
      }
    auto nearer = [](const Source& a, const Source& b) { return a.d2 < b.d2; };
    std::stable_sort(at_lights.begin(), at_lights.end(), nearer);
    std::stable_sort(sources.begin(), sources.end(), nearer);
    if (at_lights.size() > size_t(kMaxLprtSources / 2)) at_lights.resize(kMaxLprtSources / 2);
    if (sources.size() > size_t(kMaxLprtSources) - at_lights.size()) sources.resize(size_t(kMaxLprtSources) - at_lights.size());
    sources.insert(sources.begin(), at_lights.begin(), at_lights.end());
    stats.lprt_sources = sources.size();
  }

  t0 = Clock::now();
  std::vector<glm::vec3> positions;
  for (const PlacedProbe& p : placed) positions.push_back(p.position);
  std::vector<glm::vec3> source_positions;
  for (const Source& s : sources) source_positions.push_back(s.position);
  std::vector<float> lprt_values, sun_values;
  const std::vector<glm::vec3> sun_directions =
      (effects & kEffectSunBounce) && ts.representation == Representation::kShL1 ? sunSamples(world.sky, ts.sun_samples)
                                                                                 : std::vector<glm::vec3>{};
  std::vector<ProbeData> data =
      bakeTransfer(*scene, g, positions, ts, stats.transfer, source_positions, &lprt_values, sun_directions, &sun_values);
  stats.transfer_s = since(t0);

  for (size_t i = 0; i < placed.size(); ++i) {
    data[i].flags |= placed[i].flags;  // bakeTransfer may have set kProbeSkyFit
    data[i].interior = placed[i].interior;
    sector.probes.push_back(packProbe(data[i]));
  }
  if (!sources.empty()) {
    const size_t S = sources.size();
    for (const Source& s : sources) sector.lprt.sources.push_back(s.ref);
    sector.lprt_on_bases = ts.representation == Representation::kFc3;  // sh-l1: SH (transfer.h)
    sector.lprt.coeffs.resize(placed.size() * S * 12);
    for (size_t p = 0; p < placed.size(); ++p) {
      float range = 0.f;
      for (size_t q = 0; q < S * 12; ++q) range = std::max(range, std::abs(lprt_values[p * S * 12 + q]));
      if (!(range > 0.f) || !std::isfinite(range)) range = 1.f;  // all zero: any range decodes 0
      sector.probes[p].lprt_range = range;
      for (size_t q = 0; q < S * 12; ++q) sector.lprt.coeffs[p * S * 12 + q] = quantizeSnorm16(lprt_values[p * S * 12 + q], range);
    }
  }

  if (!sun_values.empty()) {
    const size_t K = sun_directions.size();
    auto sun = std::make_unique<SunBlock>();
    sun->directions = sun_directions;
    sun->ranges.resize(placed.size());
    sun->coeffs.resize(placed.size() * K * 12);
    for (size_t p = 0; p < placed.size(); ++p) {
      float range = 0.f;
      for (size_t q = 0; q < K * 12; ++q) range = std::max(range, std::abs(sun_values[p * K * 12 + q]));
      if (!(range >= kMinQuantizationRange) || !std::isfinite(range)) range = 1.f;  // all zero: any range decodes 0
      range = std::min(range, kMaxPrtRange);
      sun->ranges[p] = range;
      for (size_t q = 0; q < K * 12; ++q) sun->coeffs[p * K * 12 + q] = quantizeSnorm8(sun_values[p * K * 12 + q], range);
    }
    sector.sun = std::move(sun);
  }

  {
    // The covered probes' visibility maps (visibility.h): the fine level's test of which probes
    // see a point.
    std::vector<glm::vec3> covered;
    for (const PlacedProbe& p : placed)
      if (p.flags & kProbeCovered) covered.push_back(p.position);
    if (!covered.empty()) {
      const auto t_vis = Clock::now();
      auto vis = std::make_unique<VisibilityBlock>();
      vis->values = bakeVisibility(*scene, g, covered, settings.visibility_rays, settings.visibility_openings, stats.other_rays);
      sector.visibility = std::move(vis);
      stats.visibility_s = since(t_vis);
    }
  }

  t0 = Clock::now();
  // The index grid names the probes a lookup reads: not the light sources, which placement put
  // last (placement.h, step 7).
  const size_t looked_up = size_t(std::find_if(placed.begin(), placed.end(), [](const PlacedProbe& p) {
                                    return (p.flags & kProbeLightSource) != 0;
                                  }) - placed.begin());
  for (size_t i = looked_up; i < placed.size(); ++i) DRTV_CHECK(placed[i].flags & kProbeLightSource);
  const std::span<const glm::vec3> lookup_positions(positions.data(), looked_up);
  chooseGridExtent(lookup_positions, ground_min, sector.grid);
  {
    // Cells outside an interior that would name its probes are tested once more for being inside
    // geometry (index_grid.h): the boxes of every interior, indexed as PlacedProbe::interior is.
    std::vector<raytrace::Box> boxes;
    for (const LocalInterior& in : localInteriors(world, key, effects)) boxes.push_back(in.box);
    std::vector<uint16_t> probe_interior;
    for (size_t i = 0; i < looked_up; ++i) probe_interior.push_back(placed[i].interior);
    // The sides of the sky line: covered probes, and whether static geometry stands over a cell.
    // Only with covered probes to tell apart (kProbeCovered is cleared above without the fine
    // level): otherwise no side, and the grid of the builds before.
    std::vector<uint8_t> probe_covered;
    if (settings.grid.same_side && settings.covered_visibility)
      for (size_t i = 0; i < looked_up; ++i) probe_covered.push_back((placed[i].flags & kProbeCovered) ? 1 : 0);
    const float top = g.z_max + 1.f;
    IndexGridSides sides{probe_covered, [&](const glm::vec3& c, uint64_t& rays) {
                           return std::isfinite(detail::staticHitDistance(*scene, g, c, glm::vec3(0, 0, 1), std::max(0.f, top - c.z) + 1.f,
                                                                          kMaxGroundHits, rays));
                         }};
    fillIndexGrid(*scene, lookup_positions, settings.grid, sector.grid, stats.grid, {boxes, probe_interior}, sides);
  }
  stats.grid_s = since(t0);
  stats.bytes = encodedSectorBytes(sector.probes.size(), sector.lprt.sources.size(), sector.has_ground,
                                   sector.sun ? sector.sun->samples() : 0, coveredProbes(sector));
  stats.bytes_without_lprt = encodedSectorBytes(sector.probes.size(), 0, sector.has_ground, sector.sun ? sector.sun->samples() : 0,
                                                coveredProbes(sector));
  stats.total_s = since(t_start);
  return sector;
}

fs::path sectorDirectory(const fs::path& archive) { return fs::path(archive.string() + ".sectors"); }

namespace {


// Pass 1 of an LPRT bake: the placement of the sectors `todo_keys` and of their neighbours
// (placementKeys), read back from any placement journal in `dir` or placed now and appended to
// this shard's. Empty without LPRT.
Result<SectorPlacements> placementPass(const raytrace::WorldGeometry& geometry, const worlds::World& world, const std::string& world_name,
                                       const fs::path& dir, const std::vector<SectorKey>& todo_keys, const BakeSettings& settings,
                                       uint32_t effects, const BakeOptions& options, PlacementPass& pass) {
  SectorPlacements placements;
  const std::vector<SectorKey> needed = placementKeys(todo_keys, effects);
  if (needed.empty()) return placements;
  const auto t0 = Clock::now();
  auto placed = detail::scanJournals(dir, "placement-");
  if (!placed) return std::unexpected(placed.error());
  std::vector<SectorKey> missing;
  for (const SectorKey k : needed) {
    const auto it = placed->find(k);
    if (it == placed->end()) {
      missing.push_back(k);
      continue;
    }
    auto bytes = detail::readSector(it->second);
    if (!bytes) return std::unexpected(bytes.error());
    auto p = decodePlacement(*bytes, it->second.file.string() + " sector " + toString(k));
    if (!p) return std::unexpected(p.error());
    placements[k] = std::move(*p);
    ++pass.resumed;
  }
  auto fresh = placeSectors(geometry, world, missing, settings, effects);
  if (!fresh) return std::unexpected(fresh.error().context(world_name));
  if (!missing.empty()) {
    auto w = detail::JournalWriter::open(
        dir / ("placement-" + std::to_string(options.shard_index) + "-of-" + std::to_string(options.shard_count) + ".log"));
    if (!w) return std::unexpected(w.error());
    for (auto& [k, p] : *fresh) {
      if (auto a = w->append(k, {}, encodePlacement(p)); !a) return std::unexpected(a.error());
      placements[k] = std::move(p);
    }
  }
  const std::set<SectorKey> own(todo_keys.begin(), todo_keys.end());
  for (const SectorKey k : missing)
    if (!own.contains(k)) pass.outside_rays += placements.at(k).stats.rays;
  pass.sectors = needed.size();
  pass.outside = needed.size() - own.size();
  pass.seconds = since(t0);
  return placements;
}

// Packs every sector of `keys` from the journal records `entries` into `archive`, in key order,
// skipping empty ones; fills the report's per-sector counts from the bytes themselves (a resumed
// sector's stats may be missing).
Result<void> packArchive(const raytrace::WorldGeometry& geometry, const worlds::World& world, const std::string& world_name,
                         const fs::path& archive, const fs::path& dir, const std::vector<SectorKey>& keys,
                         const std::map<SectorKey, detail::JournalEntry>& entries, uint32_t effects, BakeReport& report) {
  const auto t0 = Clock::now();
  for (size_t i = 0; i < keys.size(); ++i)
    if (entries.find(keys[i]) == entries.end())
      return fail(dir.string() + ": sector " + toString(keys[i]) + " is missing from the journals it was written to");
  auto out = ArchiveWriter::create(archive, report.settings.zstd_level);
  if (!out) return std::unexpected(out.error());
  report.sectors_empty = 0;
  BuildingCollector buildings;
  for (size_t i = 0; i < keys.size(); ++i) {
    const detail::JournalEntry& e = entries.at(keys[i]);
    auto bytes = detail::readSector(e);
    if (!bytes) return std::unexpected(bytes.error());
    auto decoded = decodeSector(*bytes, e.file.string() + " sector " + toString(keys[i]));
    if (!decoded) return std::unexpected(decoded.error());
    if (decoded->probes.empty()) {
      ++report.sectors_empty;
      continue;
    }
    SectorStats& st = *std::find_if(report.sectors.begin(), report.sectors.end(), [&](const SectorStats& s) { return s.key == keys[i]; });
    st.probes = decoded->probes.size();
    st.lprt_sources = decoded->lprt.sources.size();
    st.bytes = bytes->size();
    st.bytes_without_lprt = encodedSectorBytes(st.probes, 0, decoded->has_ground, decoded->sun ? decoded->sun->samples() : 0,
                                               coveredProbes(*decoded));
    buildings.addSector(*decoded);
    if (auto a = out->addEncodedSector(*bytes); !a) return std::unexpected(a.error());
  }
  report.buildings = buildings.buildings();
  if (auto f = out->finish(manifestFor(geometry, world, world_name, report.settings, effects)); !f) return std::unexpected(f.error());
  report.packed = true;
  report.pack_s = since(t0);
  return {};
}


}  // namespace

static Result<BakeReport> bakeRecorded(const worlds::World& given, const std::string& world_name, const fs::path& archive,
                                const BakeOptions& options);

Result<BakeReport> bake(const worlds::World& given, const std::string& world_name, const fs::path& archive,
                        const BakeOptions& options) {
  auto report = bakeRecorded(given, world_name, archive, options);
  // A shard that fails says why in its status file, for the merge and `drtv farm status` (its
  // scheduler's log may be on another machine, or gone).
  const bool shard = !options.merge_only && options.shard_count > 1 && options.shard_index >= 0 && options.shard_index < options.shard_count;
  if (!report && shard)
    if (auto w = recordShardFailure(archive, {options.shard_index, options.shard_count}, report.error().message); !w)
      return fail(report.error().message + " (and its status could not be written: " + w.error().message + ")");
  return report;
}

static Result<BakeReport> bakeRecorded(const worlds::World& given, const std::string& world_name, const fs::path& archive,
                                const BakeOptions& options) {
  const auto t_start = Clock::now();
  if (options.shard_count < 1 || options.shard_index < 0 || options.shard_index >= options.shard_count)
    return fail("--shard " + std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count) +
                ": need 0 <= k < N");
  if (options.threads < 0) return fail("--threads " + std::to_string(options.threads) + ": must be >= 0");
  std::optional<tbb::global_control> limit;
  if (options.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));

  BakeReport report;
  report.world = world_name;
  report.archive = archive;
  report.settings = options.settings ? *options.settings : BakeSettings::forQuality(options.quality, options.seed);
  if (options.representation) report.settings.transfer.representation = *options.representation;
  else if (given.representation && !options.settings) report.settings.transfer.representation = *given.representation;
  if (options.clearance_m) report.settings.placement.clearance_m = *options.clearance_m;
  if (options.find_rooms) report.settings.rooms.enabled = *options.find_rooms;
  if (options.inside_from_neighbours) report.settings.grid.inside_from_neighbours = *options.inside_from_neighbours;
  if (options.grid_same_side) report.settings.grid.same_side = *options.grid_same_side;
  if (options.cell_sides) report.settings.transfer.cell_sides = *options.cell_sides;
  if (options.covered_visibility) report.settings.covered_visibility = *options.covered_visibility;
  if (options.visibility_rays) report.settings.visibility_rays = *options.visibility_rays;
  if (report.settings.visibility_rays < kVisRaysMin || report.settings.visibility_rays > kVisRaysMax)
    return fail("--visibility-rays " + std::to_string(report.settings.visibility_rays) + ": must be in [" +
                std::to_string(kVisRaysMin) + ", " + std::to_string(kVisRaysMax) + "]");
  if (options.light_sources) report.settings.light_sources = *options.light_sources;
  if (options.enclosed_spacing_m) report.settings.placement.setEnclosedSpacing(*options.enclosed_spacing_m);
  if (options.covered_stack_m) report.settings.placement.covered_stack_m = *options.covered_stack_m;
  if (options.sweeps) report.settings.transfer.sweeps = *options.sweeps;
  if (auto why = validateSettings(report.settings); !why) return std::unexpected(why.error().context("bake settings"));
  report.threads = options.threads > 0 ? options.threads : int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  if (options.shard_count > 1) report.shard = std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count);
  report.effects_asked = given.effects;
  // The halo depends on the lights alone: the rooms found below do not change it.
  const uint32_t given_effects = effectsToBake(given, nullptr);
  if (auto why = validateLighting(given.sky, given.lights, given.interiors); !why)
    return std::unexpected(why.error().context(world_name));

  auto t0 = Clock::now();
  // With --sectors, only the geometry those sectors gather is binned (not a whole 8192-cell terrain);
  // with LPRT that includes the ring of neighbours the placement pass places (placementKeys).
  std::optional<raytrace::SectorRange> binned = options.sectors;
  if (binned && (given_effects & kEffectLocalLights)) *binned = grownByOne(*binned);
  auto geometry = raytrace::WorldGeometry::build(given, world_name, binned, haloFor(report.settings, given_effects));
  if (!geometry) return std::unexpected(geometry.error());
  report.notes = geometry->notes();
  report.world_notes = given.notes;
  report.materials = given.materials;
  report.triangles = geometry->triangleCount();
  report.geometry_s = since(t0);

  // The sectors of this bake, in key order (ix, iy) as the manifest keeps them.
  raytrace::SectorRange range = geometry->sectors();
  if (options.sectors) {
    range.x0 = std::max(range.x0, options.sectors->x0);
    range.x1 = std::min(range.x1, options.sectors->x1);
    range.y0 = std::max(range.y0, options.sectors->y0);
    range.y1 = std::min(range.y1, options.sectors->y1);
    if (range.empty()) return fail(world_name + ": --sectors selects no sector of the world");
  }

  // Closed rooms get the artist's interior treatment (rooms.h). They are searched for over the
  // whole world, so that every shard and every --sectors bake finds the same ones (the same
  // interior indices in its probes, the same fingerprint: their sectors resume into one archive);
  // a bake binned for some sectors only bins the whole world once more for the search.
  t0 = Clock::now();
  std::optional<raytrace::WorldGeometry> whole;
  if (binned && report.settings.rooms.enabled) {
    auto w = raytrace::WorldGeometry::build(given, world_name);
    if (!w) return std::unexpected(w.error().context("the room search bins the whole world (--rooms off skips it)"));
    whole.emplace(std::move(*w));
  }
  const raytrace::WorldGeometry& searched = whole ? *whole : *geometry;
  std::optional<worlds::World> with_rooms;
  auto found = worldWithRooms(given, searched, searched.sectors(), report.settings, with_rooms, &report.rooms);
  if (!found) return std::unexpected(found.error().context(world_name));
  const worlds::World& world = **found;
  report.rooms_s = since(t0);
  const uint32_t effects = effectsToBake(world, &report.effects_skipped);
  report.effects_baked = effects;
  if (!options.merge_only)
    if (auto ok = geometry->checkBakeMemory(range, haloFor(report.settings, effects), report.threads, world_name); !ok)
      return std::unexpected(ok.error());
  const std::vector<SectorKey> keys = bakeKeys(range);
  // What each sector costs to bake, and so which shard bakes it (shard.h, shardOwners).
  const SectorCosts costs = sectorCosts(*geometry, keys, haloFor(report.settings, effects), options.costs ? &*options.costs : nullptr);
  const std::vector<int> owner = shardOwners(costs.units, options.shard_count);
  report.geometry_fingerprint = fingerprintText(geometry->fingerprint());
  report.split = costs.split;

  // The sector directory, stamped with the bake's fingerprint: a resumed bake must be the same bake.
  const fs::path dir = sectorDirectory(archive);
  const uint64_t fingerprint = bakeFingerprint(*geometry, world, report.settings, effects);
  std::vector<ShardStatus> shard_statuses;
  if (options.merge_only) {
    auto s = shardsOfThisBake(dir, fingerprintText(fingerprint), world_name, report.settings, costs.split);
    if (!s) return std::unexpected(s.error());
    shard_statuses = std::move(*s);
    report.shards = shard_statuses;
  }
  if (auto ok = claimSectorDirectory(dir, fingerprint, options.fresh); !ok) return std::unexpected(ok.error());
  std::error_code ec;

  // Which sectors this process bakes; the rest are resumed (or, on merge, must exist).
  std::vector<size_t> todo;
  std::vector<SectorStats> stats(keys.size());
  std::vector<uint8_t> have(keys.size(), 0);
  auto journal = detail::scanJournals(dir);
  if (!journal) return std::unexpected(journal.error());
  for (size_t i = 0; i < keys.size(); ++i) {
    if (const auto it = journal->find(keys[i]); it != journal->end()) {
      have[i] = 1;
      if (auto j = detail::readStats(it->second); j)
        if (auto decoded = decodeStats(*j)) stats[i] = *decoded;
      stats[i].key = keys[i];
      stats[i].resumed = true;
      continue;
    }
    if (options.merge_only) continue;
    if (owner[i] == options.shard_index) todo.push_back(i);
  }
  if (options.merge_only) {
    size_t missing = 0;
    std::string first;
    for (size_t i = 0; i < keys.size(); ++i)
      if (!have[i] && missing++ == 0) first = toString(keys[i]);
    if (missing)
      return fail(dir.string() + ": " + std::to_string(missing) + " sectors not baked yet (first " + first + ")" +
                  missingShards(dir, keys, costs.units, have, shard_statuses) + "; run the missing shards");
  }

  // The journal is opened (and locked) before the status says "running": while the shard runs it
  // holds the lock, so `drtv farm status` tells a running shard from one that was killed.
  std::optional<detail::JournalWriter> writer;
  if (!todo.empty()) {
    auto w = detail::JournalWriter::open(
        dir / ("sectors-" + std::to_string(options.shard_index) + "-of-" + std::to_string(options.shard_count) + ".log"));
    if (!w) return std::unexpected(w.error());
    writer.emplace(std::move(*w));
  }

  ShardStatus status;
  if (!options.merge_only) {
    status.index = options.shard_index;
    status.count = options.shard_count;
    status.fingerprint = fingerprintText(fingerprint);
    status.world = world_name;
    status.settings = report.settings.describe();
    status.split = costs.split;
    for (size_t i = 0; i < keys.size(); ++i)
      if (owner[i] == options.shard_index) ++status.sectors, status.cost += costs.units[i];
    if (auto w = writeShardStatus(dir, status); !w) return std::unexpected(w.error());
  }

  // Pass 1, with LPRT: the placement of every sector this process bakes and of their neighbours.
  std::vector<SectorKey> todo_keys;
  for (const size_t i : todo) todo_keys.push_back(keys[i]);
  auto placements = placementPass(*geometry, world, world_name, dir, todo_keys, report.settings, effects, options, report.placement_pass);
  if (!placements) return std::unexpected(placements.error());

  // Pass 2: bake, in parallel over sectors (and inside each sector over probes and surfels); each
  // finished sector is one record of this shard's journal (opened above).
  t0 = Clock::now();
  std::mutex mutex;
  size_t done = keys.size() - todo.size();
  if (options.progress) options.progress(done, keys.size());
  std::vector<std::optional<Error>> errors(todo.size());
  tbb::parallel_for(size_t(0), todo.size(), [&](size_t t) {
    const size_t i = todo[t];
    SectorStats st;
    auto sector = bakeSector(*geometry, world, keys[i], report.settings, effects, *placements, st);
    if (!sector) {
      errors[t] = sector.error();
      return;
    }
    const std::vector<uint8_t> bytes = encodeSector(*sector);
    const std::vector<uint8_t> typed = encodeStats(st);
    std::lock_guard lock(mutex);
    auto written = writer->append(keys[i], typed, bytes);
    if (!written) {
      errors[t] = written.error();
      return;
    }
    (*journal)[keys[i]] = std::move(*written);
    stats[i] = st;
    have[i] = 1;
    ++done;
    if (options.progress) options.progress(done, keys.size());
  });
  report.bake_s = since(t0);
  for (const auto& e : errors)
    if (e) return std::unexpected(e->context(world_name));
  if (!options.merge_only) {
    status.state = ShardStatus::State::kDone;
    status.baked = todo.size();
    status.wall_s = since(t_start);
    status.peak_rss_bytes = peakResidentBytes();
    if (auto w = writeShardStatus(dir, status); !w) return std::unexpected(w.error());
  }

  for (size_t i = 0; i < keys.size(); ++i)
    if (have[i]) {
      if (stats[i].probes == 0 && !stats[i].resumed)
        ++report.sectors_empty;
      report.sectors.push_back(stats[i]);
    }

  // A shard stops here; a whole bake (or a merge) packs the archive.
  const bool complete = std::all_of(have.begin(), have.end(), [](uint8_t h) { return h != 0; });
  if (options.shard_count == 1 && complete) {
    writer.reset();  // closes (and unlocks) this shard's journal
    if (auto ok = packArchive(*geometry, world, world_name, archive, dir, keys, *journal, effects, report); !ok)
      return std::unexpected(ok.error());
    if (!options.keep_sector_files) fs::remove_all(dir, ec);
  }
  report.wall_s = since(t_start);
  report.peak_rss_bytes = peakResidentBytes();
  return report;
}

}  // namespace drtv::baker
