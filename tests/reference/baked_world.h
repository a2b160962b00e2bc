// A world baked in memory and relit by the runtime, the way an engine would see it; shared by
// the reference tests.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "drtv/eval/accuracy.h"
#include "drtv/runtime/runtime.h"

namespace drtv::testing {
using namespace raytrace;

struct BakedWorld {
  std::vector<Sector> sectors;
  Manifest manifest;
};

inline BakedWorld bakeWorld(const worlds::World& world, baker::Quality quality,
                            std::optional<raytrace::SectorRange> range = std::nullopt) {
  auto b = baker::bakeInMemory(world, world.name, baker::BakeSettings::forQuality(quality, 1), range);
  EXPECT_TRUE(b.has_value()) << (b ? "" : b.error().message);
  if (!b) return {};
  return {std::move(b->sectors), std::move(b->manifest)};
}

// A runtime holding every sector of `baked`, lit at `hour`, its volume centred on `camera`.
inline std::unique_ptr<runtime::Runtime> relit(const BakedWorld& baked, double hour, const glm::dvec3& camera,
                                               runtime::RuntimeOptions options = {}) {
  options.components = runtime::componentsFromEffects(baked.manifest.effects);
  options.effects = baked.manifest.effects;
  options.representation = baked.manifest.representation;  // as runtimeForArchive takes it
  options.cache.max_sectors = std::max<int>(options.cache.max_sectors, int(baked.sectors.size()));
  auto rt = std::make_unique<runtime::Runtime>(options);
  EXPECT_TRUE(rt->setLighting(baked.manifest.sky, baked.manifest.lights, baked.manifest.interiors).has_value());
  EXPECT_TRUE(rt->setTime(hour).has_value());
  for (const Sector& s : baked.sectors) EXPECT_TRUE(rt->addSector(s).has_value());
  rt->update(camera);
  return rt;
}

inline glm::vec3 ambientAt(const BakedWorld& baked, double hour, const glm::dvec3& at, const glm::vec3& normal,
                           const glm::dvec3& camera) {
  return relit(baked, hour, camera)->ambient(at, normal).irradiance;
}

}  // namespace drtv::testing
