// bakeInMemory: bake.h's per-sector pipeline without files (bake.h): the accuracy table's and the tests' bake.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "drtv/baker/bake.h"

namespace drtv::baker {

Result<InMemoryBake> bakeInMemory(const worlds::World& given, const std::string& where, const BakeSettings& settings,
                                  std::optional<raytrace::SectorRange> sectors, int threads) {
  if (auto why = validateLighting(given.sky, given.lights, given.interiors); !why)
    return std::unexpected(why.error().context(where));
  if (threads < 0) return fail("threads " + std::to_string(threads) + ": must be >= 0");
  if (auto why = validateSettings(settings); !why) return std::unexpected(why.error().context(where + ": bake settings"));
  std::optional<tbb::global_control> limit;
  if (threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));
  auto geometry = raytrace::WorldGeometry::build(given, where);
  if (!geometry) return std::unexpected(geometry.error());
  raytrace::SectorRange range = geometry->sectors();
  if (sectors) {
    range.x0 = std::max(range.x0, sectors->x0);
    range.x1 = std::min(range.x1, sectors->x1);
    range.y0 = std::max(range.y0, sectors->y0);
    range.y1 = std::min(range.y1, sectors->y1);
  }
  if (range.empty()) return fail(where + ": the sector selection holds no sector of the world");
  // bake()'s rooms (rooms.h), searched for over the whole world as bake() does.
  std::optional<worlds::World> with_rooms;
  auto found = worldWithRooms(given, *geometry, geometry->sectors(), settings, with_rooms);
  if (!found) return std::unexpected(found.error().context(where));
  const worlds::World& world = **found;
  std::vector<SectorKey> keys;
  for (int32_t x = range.x0; x <= range.x1; ++x)
    for (int32_t y = range.y0; y <= range.y1; ++y) keys.push_back({x, y});

  InMemoryBake out;
  const uint32_t effects = effectsToBake(world, nullptr);
  // The sectors bake in parallel, each holding its gather: refused up front where that cannot fit.
  const int concurrent = threads > 0 ? threads : int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  if (auto ok = geometry->checkBakeMemory(range, haloFor(settings, effects), concurrent, where); !ok)
    return std::unexpected(ok.error());
  const auto t0 = std::chrono::steady_clock::now();
  // bake()'s two passes: with LPRT every sector's and its neighbours' placement first.
  auto placements = placeSectors(*geometry, world, placementKeys(keys, effects), settings, effects);
  if (!placements) return std::unexpected(placements.error().context(where));
  for (const auto& [k, p] : *placements)
    if (!std::binary_search(keys.begin(), keys.end(), k)) out.rays += p.stats.rays;
  std::vector<std::optional<Result<Sector>>> baked(keys.size());
  out.stats.resize(keys.size());
  tbb::parallel_for(size_t(0), keys.size(),
                    [&](size_t i) { baked[i] = bakeSector(*geometry, world, keys[i], settings, effects, *placements, out.stats[i]); });
  out.bake_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (size_t i = 0; i < keys.size(); ++i) {
    if (!*baked[i]) return std::unexpected(baked[i]->error());
    Sector& s = **baked[i];
    out.rays += out.stats[i].rays();
    if (s.probes.empty()) continue;
    out.probes += s.probes.size();
    out.bytes += encodedSectorBytes(s.probes.size(), s.lprt.sources.size(), s.has_ground, s.sun ? s.sun->samples() : 0, coveredProbes(s));
    out.sectors.push_back(std::move(s));
  }
  out.manifest = manifestFor(*geometry, world, where, settings, effects);
  return out;
}

}  // namespace drtv::baker
