// The ambient cube's transfer for placed sectors (cube_bake.h).
#include "drtv/baker/cube_bake.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <optional>

namespace drtv::baker {

Result<CubeBake> bakeCube(const worlds::World& given, const std::string& where, const BakeSettings& settings,
                          std::span<const Sector> sectors, int threads, const std::vector<InteriorVolume>* interiors) {
  // The interiors the sectors were baked with (the rooms found, rooms.h), for the placements.
  std::optional<worlds::World> with_rooms;
  const worlds::World& world = interiors ? worldWithInteriors(given, *interiors, with_rooms) : given;
  if (auto why = validateLighting(world.sky, world.lights, world.interiors); !why)
    return std::unexpected(why.error().context(where));
  if (auto why = validateSettings(settings); !why) return std::unexpected(why.error().context(where + ": bake settings"));
  std::optional<tbb::global_control> limit;
  if (threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));
  const auto t0 = std::chrono::steady_clock::now();
  auto geometry = raytrace::WorldGeometry::build(world, where);
  if (!geometry) return std::unexpected(geometry.error());
  const uint32_t effects = effectsToBake(world, nullptr);
  const bool lprt = (effects & kEffectLocalLights) != 0;
  std::vector<SectorKey> keys;
  for (const Sector& s : sectors) keys.push_back(s.key);
  CubeBake out;
  SectorPlacements placements;
  if (lprt) {
    auto p = placeSectors(*geometry, world, placementKeys(keys, effects), settings, effects);
    if (!p) return std::unexpected(p.error().context(where));
    for (const auto& [k, sp] : *p) out.rays += sp.stats.rays;
    placements = std::move(*p);
  }
  TransferSettings ts = settings.transfer;  // as bakeSector sets it
  ts.prt = (effects & (kEffectSunBounce | kEffectSkyBounce)) != 0;
  ts.sky_visibility = (effects & kEffectDirectSky) != 0;
  const std::vector<glm::vec3> sun_directions =
      (effects & kEffectSunBounce) ? sunSamples(world.sky, ts.sun_samples) : std::vector<glm::vec3>{};
  out.sectors.resize(sectors.size());
  std::vector<std::optional<Error>> errors(sectors.size());
  std::vector<TransferStats> stats(sectors.size());
  tbb::parallel_for(size_t(0), sectors.size(), [&](size_t i) {
    const Sector& sector = sectors[i];
    const raytrace::SectorGeometry g = geometry->gather(sector.key, haloFor(settings, effects));
    auto scene = raytrace::RayScene::build(g.vertices, g.twoSided());
    if (!scene) {
      errors[i] = scene.error().context("sector " + toString(sector.key));
      return;
    }
    std::vector<glm::vec3> positions;
    for (const ProbeRecord& r : sector.probes) positions.push_back(unpackProbe(r).position);
    // The record's LPRT sources, located in this sector's frame (bakeSector's shift).
    std::vector<glm::vec3> sources;
    for (const LprtSource& src : sector.lprt.sources) {
      const auto it = placements.find(SectorKey{sector.key.ix + src.dx, sector.key.iy + src.dy});
      DRTV_CHECK(it != placements.end());
      DRTV_CHECK_LT(size_t(src.probe), it->second.probes.size());
      sources.push_back(it->second.probes[src.probe].position +
                        glm::vec3(float(src.dx * kSectorSizeM), float(src.dy * kSectorSizeM), 0.f));
    }
    CubeSector& cs = out.sectors[i];
    cs.key = sector.key;
    cs.sun_directions = ts.prt ? sun_directions : std::vector<glm::vec3>{};
    (void)bakeTransfer(*scene, g, positions, ts, stats[i], sources, nullptr, cs.sun_directions, nullptr, &cs.transfer);
  });
  for (size_t i = 0; i < sectors.size(); ++i) {
    if (errors[i]) return std::unexpected(*errors[i]);
    out.rays += stats[i].probe_rays + stats[i].surfel_rays + stats[i].lprt_rays + stats[i].sun_rays;
  }
  out.bake_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace drtv::baker
