// The bake orchestration: per-sector pipeline, sector files, resumption, shards, packing.
// See bake.h for the overview and references.
#include "drtv/baker/bake.h"

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
#include <map>
#include <mutex>
#include <sstream>

#include "drtv/baker/sampling.h"
#include "sector_journal.h"
#include "stats_json.h"
#include "stopwatch.h"

namespace drtv::baker {
namespace fs = std::filesystem;
namespace {

using detail::Clock;
using detail::since;

// Ground-map rays start this far above the gathered geometry.
constexpr float kGroundRayMarginM = 10.f;
// Hits stepped through per ground ray (vegetation is passed through to reach the ground).
constexpr int kMaxGroundHits = 128;
// Version of what the sector journals hold; part of the resume fingerprint (2: journals instead
// of a pair of files per sector; 3: records keep their LPRT source positions for packing).
constexpr int kBakeFormat = 3;

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool isStatic(uint8_t cls) {
  return cls == uint8_t(worlds::InstanceClass::kTerrain) || cls == uint8_t(worlds::InstanceClass::kStatic);
}

// Highest terrain/static surface under (x, y), local frame; NaN if none.
float groundAt(const RayScene& scene, const SectorGeometry& g, float x, float y, uint64_t& rays) {
  const glm::vec3 origin(x, y, g.z_max + kGroundRayMarginM);
  const float len = g.z_max - g.z_min + 2.f * kGroundRayMarginM;
  float t = 0.f;
  for (int k = 0; k < kMaxGroundHits; ++k) {
    const Hit h = scene.intersect(Ray{origin, t, glm::vec3(0, 0, -1), len});
    ++rays;
    if (!h.hit()) break;
    if (isStatic(g.cls[h.prim])) return origin.z - h.t;
    t = std::max(h.t + 1e-4f, std::nextafter(h.t, INFINITY) * (1.f + 1e-6f));  // moves past the hit at any distance
  }
  return NAN;
}


Result<void> writeAtomically(const fs::path& path, const void* data, size_t size) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) return fail(tmp.string() + ": cannot open for writing");
    f.write(static_cast<const char*>(data), std::streamsize(size));
    f.flush();
    if (!f) return fail(tmp.string() + ": write failed");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return fail(path.string() + ": rename failed: " + ec.message());
  return {};
}

Result<std::vector<uint8_t>> readFile(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return fail(path.string() + ": cannot open");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return bytes;
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

}  // namespace

std::string validateSettings(const BakeSettings& s) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  const PlacementSettings& p = s.placement;
  if (!in(p.column_spacing_m, 1.0 / 16, 64.0)) return "column_spacing_m must be in [1/16, 64] m";
  if (!in(p.vegetation_spacing_m, 1.0 / 16, 64.0)) return "vegetation_spacing_m must be in [1/16, 64] m";
  if (!in(p.lift_m, 0.0, 64.0)) return "lift_m must be in [0, 64] m";
  if (!in(p.min_horizontal_m, 0.0, 64.0) || !in(p.min_vertical_m, 0.0, 1e4)) return "minimum probe distances must be finite and >= 0";
  if (p.inside_test_rays < 0 || p.inside_test_rays > (1 << 16)) return "inside_test_rays must be in [0, 65536]";
  if (!in(p.inside_test_range_m, 0.0, 64.0)) return "inside_test_range_m must be in [0, 64] m";
  const TransferSettings& t = s.transfer;
  if (t.probe_rays_per_basis < 1 || t.probe_rays_per_basis > (1 << 16)) return "probe_rays_per_basis must be in [1, 65536]";
  if (t.surfel_rays < 1 || t.surfel_rays > (1 << 16)) return "surfel_rays must be in [1, 65536]";
  if (!in(t.surfel_cell_m, 0.25, 64.0)) return "surfel_cell_m must be in [0.25, 64] m (cell keys assume >= 0.25 m)";
  if (t.bounces < 1 || t.bounces > 64) return "bounces must be in [1, 64]";
  if (s.grid.visibility_candidates < 1 || s.grid.visibility_candidates > 255) return "visibility_candidates must be in [1, 255]";
  if (!in(s.halo_m, 0.0, 1024.0) || !in(s.lprt_halo_m, 0.0, 1024.0)) return "halos must be in [0, 1024] m";
  return {};
}

Manifest manifestFor(const WorldGeometry& geometry, const worlds::World& world, const std::string& world_name,
                     const BakeSettings& settings, uint32_t effects) {
  Manifest m;
  m.bounds_min = geometry.boundsMin();
  m.bounds_max = geometry.boundsMax();
  m.sector_size_m = kSectorSizeM;
  m.effects = effects;
  m.settings = settings.describe();
  m.settings.emplace_back("world", world.name.empty() ? world_name : world.name);
  m.sky = world.sky;
  m.lights = world.lights;
  m.interiors = world.interiors;
  return m;
}

const char* qualityName(Quality q) {
  switch (q) {
    case Quality::kDraft: return "draft";
    case Quality::kDefault: return "default";
    case Quality::kHigh: return "high";
  }
  return "?";
}

std::optional<Quality> parseQuality(std::string_view name) {
  if (name == "draft") return Quality::kDraft;
  if (name == "default") return Quality::kDefault;
  if (name == "high") return Quality::kHigh;
  return std::nullopt;
}

BakeSettings BakeSettings::forQuality(Quality q, uint64_t seed) {
  BakeSettings s;
  s.quality = q;
  s.placement.seed = seed;
  s.transfer.seed = seed;
  switch (q) {
    case Quality::kDraft:
      s.transfer.probe_rays_per_basis = 32;
      s.transfer.surfel_rays = 12;
      s.transfer.surfel_cell_m = 3.f;
      s.transfer.bounces = 2;
      s.grid.visibility_candidates = 4;
      break;
    case Quality::kDefault:
      s.transfer.probe_rays_per_basis = 128;
      s.transfer.surfel_rays = 24;
      s.transfer.surfel_cell_m = 2.f;
      s.transfer.bounces = 2;
      s.grid.visibility_candidates = 8;
      break;
    case Quality::kHigh:
      s.transfer.probe_rays_per_basis = 512;
      s.transfer.surfel_rays = 64;
      s.transfer.surfel_cell_m = 1.f;
      s.transfer.bounces = 3;
      s.grid.visibility_candidates = 16;
      break;
  }
  return s;
}

std::vector<std::pair<std::string, std::string>> BakeSettings::describe() const {
  return {
      {"quality", qualityName(quality)},
      {"seed", std::to_string(transfer.seed)},
      {"probe_rays_per_basis", std::to_string(transfer.probe_rays_per_basis)},
      {"surfel_rays", std::to_string(transfer.surfel_rays)},
      {"surfel_cell_m", fmt(transfer.surfel_cell_m)},
      {"bounces", std::to_string(transfer.bounces)},
      {"column_spacing_m", fmt(placement.column_spacing_m)},
      {"vegetation_spacing_m", fmt(placement.vegetation_spacing_m)},
      {"lift_m", fmt(placement.lift_m)},
      {"min_horizontal_m", fmt(placement.min_horizontal_m)},
      {"min_vertical_m", fmt(placement.min_vertical_m)},
      {"inside_test_rays", std::to_string(placement.inside_test_rays)},
      {"grid_visibility_candidates", std::to_string(grid.visibility_candidates)},
      {"halo_m", fmt(halo_m)},
      {"lprt_halo_m", fmt(lprt_halo_m)},
      {"zstd_level", std::to_string(zstd_level)},
  };
}

uint32_t effectsToBake(const worlds::World& world, std::vector<std::string>* skipped) {
  uint32_t e = world.effects & kAllEffects;
  auto skip = [&](Effect effect, const std::string& why) {
    if (!(e & effect)) return;
    e &= ~uint32_t(effect);
    if (skipped) skipped->push_back(std::string(effectName(effect)) + ": " + why);
  };
  if (world.lights.empty()) skip(kEffectLocalLights, "the world has no point lights");
  if (world.interiors.empty()) skip(kEffectInteriors, "the world has no interior volumes");
  if (skipped)
    for (uint32_t bit = 1; bit <= kEffectVolumeBlur; bit <<= 1)
      if (!(world.effects & bit)) skipped->push_back(std::string(effectName(Effect(bit))) + ": not asked for by the world");
  return e;
}

double haloFor(const BakeSettings& settings, uint32_t effects) {
  return (effects & kEffectLocalLights) ? settings.lprt_halo_m : settings.halo_m;
}

Result<Sector> bakeSector(const WorldGeometry& geometry, const worlds::World& world, SectorKey key,
                          const BakeSettings& settings, uint32_t effects, SectorStats& stats) {
  const auto t_start = Clock::now();
  stats = SectorStats{};
  stats.key = key;
  const bool lprt = (effects & kEffectLocalLights) != 0;
  TransferSettings ts = settings.transfer;
  ts.prt = (effects & (kEffectSunBounce | kEffectSkyBounce)) != 0;
  ts.sky_visibility = (effects & kEffectDirectSky) != 0;

  auto t0 = Clock::now();
  const SectorGeometry g = geometry.gather(key, haloFor(settings, effects));
  stats.triangles = g.triangleCount();
  stats.gather_s = since(t0);
  t0 = Clock::now();
  auto scene = RayScene::build(g.vertices);
  if (!scene) return std::unexpected(scene.error().context("sector " + toString(key)));
  stats.build_s = since(t0);

  t0 = Clock::now();
  const std::vector<LocalInterior> interiors = localInteriors(world, key, effects);
  const std::vector<PlacedProbe> placed = placeProbes(*scene, g, {0, 0}, interiors, settings.placement, stats.placement);
  stats.placement_s = since(t0);

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

  // LPRT sources: the 128 probes nearest to the sector's centre among this sector's and its 8
  // neighbours' (placed again here, with this sector's halo scene: deterministic and identical).
  struct Source {
    LprtSource ref;
    glm::vec3 position;
    float d2;
  };
  std::vector<Source> sources;
  if (lprt) {
    t0 = Clock::now();
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        PlacementStats ps;
        const std::vector<PlacedProbe> nb =
            (dx == 0 && dy == 0) ? placed
                                 : placeProbes(*scene, g, {dx, dy}, localInteriors(world, key, effects), settings.placement, ps);
        stats.other_rays += ps.rays;
        for (size_t i = 0; i < nb.size(); ++i) {
          const glm::vec2 d = glm::vec2(nb[i].position) - glm::vec2(float(kSectorSizeM / 2));
          sources.push_back({{int8_t(dx), int8_t(dy), uint8_t(i)}, nb[i].position, glm::dot(d, d)});
        }
      }
    std::stable_sort(sources.begin(), sources.end(), [](const Source& a, const Source& b) { return a.d2 < b.d2; });
    if (sources.size() > size_t(kMaxLprtSources)) sources.resize(kMaxLprtSources);
    stats.lprt_sources = sources.size();
    for (const Source& s : sources) stats.lprt_source_positions.push_back(s.position);
    stats.placement_s += since(t0);
  }

  t0 = Clock::now();
  std::vector<glm::vec3> positions;
  for (const PlacedProbe& p : placed) positions.push_back(p.position);
  std::vector<glm::vec3> source_positions;
  for (const Source& s : sources) source_positions.push_back(s.position);
  std::vector<float> lprt_values;
  std::vector<ProbeData> data = bakeTransfer(*scene, g, positions, ts, stats.transfer, source_positions, &lprt_values);
  stats.transfer_s = since(t0);

  for (size_t i = 0; i < placed.size(); ++i) {
    data[i].flags = placed[i].flags;
    data[i].interior = placed[i].interior;
    sector.probes.push_back(packProbe(data[i]));
  }
  if (!sources.empty()) {
    const size_t S = sources.size();
    for (const Source& s : sources) sector.lprt.sources.push_back(s.ref);
    sector.lprt.on_bases = true;
    sector.lprt.coeffs.resize(placed.size() * S * 12);
    for (size_t p = 0; p < placed.size(); ++p) {
      float range = 0.f;
      for (size_t q = 0; q < S * 12; ++q) range = std::max(range, std::abs(lprt_values[p * S * 12 + q]));
      if (!(range > 0.f) || !std::isfinite(range)) range = 1.f;  // all zero: any range decodes 0
      sector.probes[p].lprt_range = range;
      for (size_t q = 0; q < S * 12; ++q) sector.lprt.coeffs[p * S * 12 + q] = quantizeSnorm16(lprt_values[p * S * 12 + q], range);
    }
  }

  t0 = Clock::now();
  chooseGridExtent(positions, ground_min, sector.grid);
  fillIndexGrid(*scene, positions, settings.grid, sector.grid, stats.grid);
  stats.grid_s = since(t0);
  stats.bytes = encodedSectorBytes(sector.probes.size(), sector.lprt.sources.size(), sector.has_ground);
  stats.bytes_without_lprt = encodedSectorBytes(sector.probes.size(), 0, sector.has_ground);
  stats.total_s = since(t_start);
  return sector;
}

Result<size_t> reconcileLprtSources(Sector& sector, std::span<const glm::vec3> assumed,
                                    const std::function<std::optional<std::span<const glm::vec3>>(SectorKey)>& probe_positions) {
  const std::string where = "sector " + toString(sector.key) + ": ";
  if (assumed.size() != sector.lprt.sources.size())
    return fail(where + "bug: " + std::to_string(sector.lprt.sources.size()) + " LPRT sources but " + std::to_string(assumed.size()) +
                " recorded source positions");
  const float tol2 = kLprtSourceToleranceM * kLprtSourceToleranceM;
  size_t reindexed = 0;
  for (size_t j = 0; j < assumed.size(); ++j) {
    LprtSource& ref = sector.lprt.sources[j];
    const SectorKey nk{sector.key.ix + ref.dx, sector.key.iy + ref.dy};
    const std::optional<std::span<const glm::vec3>> in_bake = probe_positions(nk);
    if (!in_bake) continue;  // a neighbour outside the baked range (--sectors): nothing to check
    const std::span<const glm::vec3> probes = *in_bake;
    // The neighbour's probes in this sector's frame: x, y shifted by whole sectors, z is world z.
    const glm::vec3 shift(float(ref.dx * kSectorSizeM), float(ref.dy * kSectorSizeM), 0.f);
    auto d2 = [&](size_t i) {
      const glm::vec3 d = probes[i] + shift - assumed[j];
      return glm::dot(d, d);
    };
    if (ref.probe < probes.size() && d2(ref.probe) <= tol2) continue;
    size_t best = probes.size();
    for (size_t i = 0; i < probes.size(); ++i)
      if (d2(i) <= tol2 && (best == probes.size() || d2(i) < d2(best))) best = i;
    if (best == probes.size())
      return fail(where + "bug: LPRT source " + std::to_string(j) + " was baked for a probe of sector " + toString(nk) + " at (" +
                  std::to_string(assumed[j].x) + ", " + std::to_string(assumed[j].y) + ", " + std::to_string(assumed[j].z) +
                  ") in this sector's frame, and that sector has no probe there");
    ref.probe = uint8_t(best);
    ++reindexed;
  }
  return reindexed;
}

fs::path sectorDirectory(const fs::path& archive) { return fs::path(archive.string() + ".sectors"); }

Result<BakeReport> bake(const worlds::World& world, const std::string& world_name, const fs::path& archive,
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
  if (std::string why = validateSettings(report.settings); !why.empty()) return fail("bake settings: " + why);
  report.threads = options.threads > 0 ? options.threads : int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  if (options.shard_count > 1) report.shard = std::to_string(options.shard_index) + "/" + std::to_string(options.shard_count);
  report.effects_asked = world.effects;
  const uint32_t effects = effectsToBake(world, &report.effects_skipped);
  report.effects_baked = effects;
  if (std::string why = validateLighting(world.sky, world.lights, world.interiors); !why.empty())
    return fail(world_name + ": " + why);

  auto t0 = Clock::now();
  // With --sectors, only the geometry those sectors gather is binned (not a whole 8192-cell terrain).
  auto geometry = WorldGeometry::build(world, world_name, options.sectors, haloFor(report.settings, effects));
  if (!geometry) return std::unexpected(geometry.error());
  report.notes = geometry->notes();
  report.triangles = geometry->triangleCount();
  report.geometry_s = since(t0);

  // The sectors of this bake, in key order (ix, iy) as the manifest keeps them.
  SectorRange range = geometry->sectors();
  if (options.sectors) {
    range.x0 = std::max(range.x0, options.sectors->x0);
    range.x1 = std::min(range.x1, options.sectors->x1);
    range.y0 = std::max(range.y0, options.sectors->y0);
    range.y1 = std::min(range.y1, options.sectors->y1);
    if (range.empty()) return fail(world_name + ": --sectors selects no sector of the world");
  }
  if (!options.merge_only)
    if (auto ok = geometry->checkBakeMemory(range, haloFor(report.settings, effects), report.threads, world_name); !ok)
      return std::unexpected(ok.error());
  std::vector<SectorKey> keys;
  for (int32_t x = range.x0; x <= range.x1; ++x)
    for (int32_t y = range.y0; y <= range.y1; ++y) keys.push_back({x, y});

  // The sector directory and its fingerprint: a resumed bake must be the same bake.
  const fs::path dir = sectorDirectory(archive);
  uint64_t fingerprint = hashKey(geometry->fingerprint(), effects, kBakeFormat);
  // Text hashed with XXH3, not std::hash: the stamp outlives the build (std::hash may change with
  // the standard library, and a rebuilt drtv would then refuse to resume its own bake).
  auto textHash = [](const std::string& t) { return uint64_t(XXH3_64bits(t.data(), t.size())); };
  for (const auto& [k, v] : report.settings.describe()) fingerprint = hashKey(fingerprint, textHash(k + "=" + v));
  // Interiors decide probe flags and indices: every field, exactly (bit patterns, not text).
  for (const InteriorVolume& v : world.interiors) {
    fingerprint = hashKey(fingerprint, textHash(v.name));
    for (const glm::dvec3& p : {v.probe_position, v.min, v.max})
      for (int a = 0; a < 3; ++a) fingerprint = hashKey(fingerprint, std::bit_cast<uint64_t>(p[a]));
    fingerprint = hashKey(fingerprint, uint64_t(std::bit_cast<uint32_t>(v.blend_distance_m)));
  }
  char fp_text[32];
  std::snprintf(fp_text, sizeof fp_text, "%016llx", static_cast<unsigned long long>(fingerprint));
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  const fs::path stamp = dir / "bake.txt";
  if (fs::exists(stamp, ec)) {
    auto old = readFile(stamp);
    const std::string text = old ? std::string(old->begin(), old->end()) : "";
    if (text != fp_text) {
      if (!options.fresh)
        return fail(dir.string() + ": holds sectors of a different bake (other world, quality, settings or drtv version); pass --fresh to discard them");
      if (auto r = detail::removeJournals(dir); !r) return std::unexpected(r.error());
    }
  }
  if (auto w = writeAtomically(stamp, fp_text, std::strlen(fp_text)); !w) return std::unexpected(w.error());

  // Which sectors this process bakes; the rest are resumed (or, on merge, must exist).
  std::vector<size_t> todo;
  std::vector<SectorStats> stats(keys.size());
  std::vector<uint8_t> have(keys.size(), 0);
  auto journal = detail::scanJournals(dir);
  if (!journal) return std::unexpected(journal.error());
  for (size_t i = 0; i < keys.size(); ++i) {
    if (const auto it = journal->find(keys[i]); it != journal->end()) {
      have[i] = 1;
      if (auto j = detail::readStats(it->second); j) {
        const auto parsed = nlohmann::json::parse(j->begin(), j->end(), nullptr, false);
        if (!parsed.is_discarded()) stats[i] = sectorStatsFromJson(parsed);
      }
      stats[i].key = keys[i];
      stats[i].resumed = true;
      continue;
    }
    if (options.merge_only) continue;
    if (i % size_t(options.shard_count) == size_t(options.shard_index)) todo.push_back(i);
  }
  if (options.merge_only) {
    size_t missing = 0;
    std::string first;
    for (size_t i = 0; i < keys.size(); ++i)
      if (!have[i] && missing++ == 0) first = toString(keys[i]);
    if (missing) return fail(dir.string() + ": " + std::to_string(missing) + " sectors not baked yet (first " + first + "); run the missing shards");
  }

  // Bake, in parallel over sectors (and inside each sector over probes and surfels); each
  // finished sector is one record of this shard's journal.
  std::optional<detail::JournalWriter> writer;
  if (!todo.empty()) {
    auto w = detail::JournalWriter::open(
        dir / ("sectors-" + std::to_string(options.shard_index) + "-of-" + std::to_string(options.shard_count) + ".log"));
    if (!w) return std::unexpected(w.error());
    writer.emplace(std::move(*w));
  }
  t0 = Clock::now();
  std::mutex mutex;
  size_t done = keys.size() - todo.size();
  if (options.progress) options.progress(done, keys.size());
  std::vector<std::optional<Error>> errors(todo.size());
  tbb::parallel_for(size_t(0), todo.size(), [&](size_t t) {
    const size_t i = todo[t];
    SectorStats st;
    auto sector = bakeSector(*geometry, world, keys[i], report.settings, effects, st);
    if (!sector) {
      errors[t] = sector.error();
      return;
    }
    const std::vector<uint8_t> bytes = encodeSector(*sector);
    nlohmann::json record = toJson(st);
    if (!st.lprt_source_positions.empty()) {
      nlohmann::json& a = record["lprt_source_positions"] = nlohmann::json::array();
      for (const glm::vec3& p : st.lprt_source_positions) a.push_back({p.x, p.y, p.z});
    }
    const std::string js = record.dump();
    st.lprt_source_positions.clear();  // the report does not carry them
    std::lock_guard lock(mutex);
    auto written = writer->append(keys[i], js, bytes);
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

  for (size_t i = 0; i < keys.size(); ++i)
    if (have[i]) {
      if (stats[i].probes == 0 && !stats[i].resumed)
        ++report.sectors_empty;
      report.sectors.push_back(stats[i]);
    }

  // A shard stops here; a whole bake (or a merge) packs the archive.
  const bool complete = std::all_of(have.begin(), have.end(), [](uint8_t h) { return h != 0; });
  if (options.shard_count == 1 && complete) {
    t0 = Clock::now();
    writer.reset();  // closes (and unlocks) this shard's journal
    // Every record: those the scan found at the start and those this process appended.
    const auto& entries = journal;
    for (size_t i = 0; i < keys.size(); ++i)
      if (entries->find(keys[i]) == entries->end())
        return fail(dir.string() + ": sector " + toString(keys[i]) + " is missing from the journals it was written to");
    auto sectorOf = [&](size_t i) -> Result<std::pair<std::vector<uint8_t>, Sector>> {
      const detail::JournalEntry& e = entries->at(keys[i]);
      auto bytes = detail::readSector(e);
      if (!bytes) return std::unexpected(bytes.error());
      auto decoded = decodeSector(*bytes, e.file.string() + " sector " + toString(keys[i]));
      if (!decoded) return std::unexpected(decoded.error());
      return std::pair{std::move(*bytes), std::move(*decoded)};
    };
    // With LPRT, every source must name the probe its sector baked for (reconcileLprtSources):
    // first every sector's probe positions, then each sector checked as it is packed.
    std::map<SectorKey, std::vector<glm::vec3>> probe_positions;
    if (effects & kEffectLocalLights)
      for (size_t i = 0; i < keys.size(); ++i) {
        auto s = sectorOf(i);
        if (!s) return std::unexpected(s.error());
        std::vector<glm::vec3>& p = probe_positions[keys[i]];
        for (const ProbeRecord& r : s->second.probes) p.emplace_back(r.position[0], r.position[1], r.position[2]);
      }
    auto out = ArchiveWriter::create(archive, report.settings.zstd_level);
    if (!out) return std::unexpected(out.error());
    report.sectors_empty = 0;
    size_t reindexed = 0;
    for (size_t i = 0; i < keys.size(); ++i) {
      auto s = sectorOf(i);
      if (!s) return std::unexpected(s.error());
      std::vector<uint8_t>* bytes = &s->first;
      Sector* decoded = &s->second;
      if (decoded->probes.empty()) {
        ++report.sectors_empty;
        continue;
      }
      if (!decoded->lprt.sources.empty()) {
        std::vector<glm::vec3> assumed;
        auto j = detail::readStats(entries->at(keys[i]));
        if (!j) return std::unexpected(j.error());
        const auto parsed = nlohmann::json::parse(j->begin(), j->end(), nullptr, false);
        if (!parsed.is_discarded() && parsed.contains("lprt_source_positions") && parsed["lprt_source_positions"].is_array())
          for (const auto& p : parsed["lprt_source_positions"])
            if (p.is_array() && p.size() == 3 && p[0].is_number() && p[1].is_number() && p[2].is_number())
              assumed.emplace_back(p[0].get<float>(), p[1].get<float>(), p[2].get<float>());
        auto fixed = reconcileLprtSources(*decoded, assumed, [&](SectorKey k) -> std::optional<std::span<const glm::vec3>> {
          const auto it = probe_positions.find(k);
          if (it == probe_positions.end()) return std::nullopt;
          return std::span<const glm::vec3>(it->second);
        });
        if (!fixed) return std::unexpected(fixed.error().context(world_name));
        if (*fixed > 0) {
          reindexed += *fixed;
          *bytes = encodeSector(*decoded);
        }
      }
      // A resumed sector's stats may be missing: take the counts from the bytes themselves.
      SectorStats& st = *std::find_if(report.sectors.begin(), report.sectors.end(), [&](const SectorStats& s) { return s.key == keys[i]; });
      st.probes = decoded->probes.size();
      st.lprt_sources = decoded->lprt.sources.size();
      st.bytes = bytes->size();
      st.bytes_without_lprt = encodedSectorBytes(st.probes, 0, decoded->has_ground);
      if (auto a = out->addEncodedSector(*bytes); !a) return std::unexpected(a.error());
    }
    if (auto f = out->finish(manifestFor(*geometry, world, world_name, report.settings, effects)); !f) return std::unexpected(f.error());
    if (reindexed > 0)
      report.notes.push_back(std::to_string(reindexed) + " LPRT sources named a neighbour's probe by another index than that sector gave it; re-indexed at packing");
    report.packed = true;
    report.pack_s = since(t0);
    if (!options.keep_sector_files) fs::remove_all(dir, ec);
  }
  report.wall_s = since(t_start);
  return report;
}

}  // namespace drtv::baker
