// Local lights (LPRT) against physics where it has a plain answer: a lamp inside a closed room
// does not light the outside of its roof. The talk's runtime spreads a light onto the source
// probes nearest to it; a probe standing on the roof is often among them.
#include <cstdio>
#include <optional>

#include <gtest/gtest.h>

#include "../baker/test_worlds.h"
#include "baked_world.h"
#include "drtv/reference/reference.h"
#include "drtv/worlds/load.h"

namespace drtv::testing {
using namespace raytrace;
using namespace reference;
using namespace eval;
namespace {

using baker::test::add;
using baker::test::box;

// ALampHungHighLightsTheGroundBelowItAsThePathTracerDoes: the summed error over the three points,
// as a share of the reference's sum: 0.43 measured (quoted there), with room for the bake's noise;
// the share kept whole on its source (1.19) and a 2 m footprint (0.72) fail it.
constexpr double kHungLampTolerance = 0.6;

// A closed room (walls 0.4 m, roof slab 0.3 m, no door) on a ground plane, with a lamp 0.5 m
// under its roof: its room spans [27.4, 36.6] x [28.4, 35.6] x [0, 3] in sector (0, 0).
worlds::World closedRoomWithLamp() {
  worlds::World w = baker::test::planeWorld(64.0, {0.4f, 0.4f, 0.4f});
  w.name = "closed room";
  const glm::vec3 c(32.f, 32.f, 0.f), lo = c - glm::vec3(5, 4, 0), hi = c + glm::vec3(5, 4, 3);
  const glm::vec3 a(0.7f, 0.7f, 0.7f);
  const auto wall = worlds::InstanceClass::kStatic;
  add(w, box({lo.x, lo.y, lo.z}, {lo.x + 0.4f, hi.y, hi.z}, a, "west wall"), wall);
  add(w, box({hi.x - 0.4f, lo.y, lo.z}, {hi.x, hi.y, hi.z}, a, "east wall"), wall);
  add(w, box({lo.x + 0.4f, hi.y - 0.4f, lo.z}, {hi.x - 0.4f, hi.y, hi.z}, a, "north wall"), wall);
  add(w, box({lo.x + 0.4f, lo.y, lo.z}, {hi.x - 0.4f, lo.y + 0.4f, hi.z}, a, "south wall"), wall);
  add(w, box({lo.x - 0.3f, lo.y - 0.3f, hi.z}, {hi.x + 0.3f, hi.y + 0.3f, hi.z + 0.3f}, a, "roof"), wall);
  w.lights.push_back({"lamp", {32.0, 33.0, 2.5}, glm::vec3(40.f), 12.f});
  w.effects |= kEffectLocalLights;
  return w;
}

// The lamp's energy goes to source probes inside its room only. The talk's rule (the nearest
// sources within the light's radius) also feeds probes outside the walls and on the roof, which
// then light the roof's outside and the ground around the house; the reference gives those
// nothing (checked below).
TEST(LocalLights, ALampInAClosedRoomLendsItsLightOnlyToProbesInTheRoom) {
  const worlds::World w = closedRoomWithLamp();
  const BakedWorld baked = bakeWorld(w, baker::Quality::kDraft);
  ASSERT_FALSE(baked.sectors.empty());
  const glm::dvec3 room_lo(27.4, 28.4, 0.0), room_hi(36.6, 35.6, 3.0);
  auto inRoom = [&](const glm::dvec3& p) {
    return glm::all(glm::greaterThan(p, room_lo)) && glm::all(glm::lessThan(p, room_hi));
  };
  // The bake put a source where the lamp stands (baker/placement.h, step 7), which takes the lamp
  // whole: inside the room by construction.
  {
    auto rt = relit(baked, 23.0, {32, 32, 2}, {});
    const std::vector<runtime::LightShare> shares = rt->cache().distributeLights(baked.manifest.lights);
    ASSERT_EQ(shares.size(), 1u);
    EXPECT_EQ(shares[0].colour, baked.manifest.lights[0].intensity) << "the whole lamp, no footprint factor";
    const glm::dvec3 at = rt->cache().worldPosition(shares[0].probe);
    EXPECT_LT(glm::length(at - baked.manifest.lights[0].position), 1e-4) << "on the lamp's own source";
  }
  // How a light is shared out where no source stands at it (a moving light): as above with the
  // lamp's own source left unused. The talk's rule is shown leaking with the room's one probe of
  // the placement before 2026-12-06; with the 2 m spacing in enclosed spaces (placement.h) the
  // four sources nearest the lamp are all the room's.
  baker::BakeSettings sparse = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
  sparse.placement.setEnclosedSpacing(0.0);
  auto sparse_bake = baker::bakeInMemory(w, w.name, sparse);
  ASSERT_TRUE(sparse_bake.has_value());
  const BakedWorld one_probe{std::move(sparse_bake->sectors), std::move(sparse_bake->manifest)};
  for (const auto mode : {runtime::LightSources::kVisibleFromLight, runtime::LightSources::kNearest})
    for (const BakedWorld* b : {&baked, &one_probe}) {
      runtime::RuntimeOptions o;
      o.cache.light_sources = mode;
      o.cache.own_light_sources = false;
      auto rt = relit(*b, 23.0, {32, 32, 2}, o);
      float inside = 0.f, outside = 0.f;
      for (const runtime::LightShare& sh : rt->cache().distributeLights(b->manifest.lights))
        (inRoom(rt->cache().worldPosition(sh.probe)) ? inside : outside) += sh.colour.g;
      // (A share is the light's intensity scaled by the footprint factor, probe_cache.h: they need
      // not sum to the light's intensity.)
      const char* which = b == &baked ? "the default placement" : "the room's one probe";
      if (mode == runtime::LightSources::kVisibleFromLight) {
        EXPECT_GT(inside, 0.f) << which << ": the lamp goes to the room's probes";
        EXPECT_EQ(outside, 0.f) << which << ": and only to them";
      } else if (b == &one_probe) {
        EXPECT_GT(outside, 0.25f * (inside + outside)) << "the talk's nearest rule leaks here (what the default avoids)";
      }
    }

  // The reference: the roof's top and the ground outside get nothing of the lamp.
  auto scene = reference::ReferenceScene::build(w, "closed room");
  ASSERT_TRUE(scene);
  reference::ReferenceLighting lighting{w.sky, 23.0, w.lights};
  reference::ReferenceSettings settings;
  settings.samples = 256;
  const double floor = reference::referenceIrradiance(*scene, lighting, {{31.0, 31.0, 0.0}, {0, 0, 1}}, settings).parts[reference::kRefLocalLights].mean.g;
  EXPECT_GT(floor, 0.1);
  for (const glm::dvec3 at : {glm::dvec3(31.0, 31.0, 3.3), glm::dvec3(40.0, 31.0, 0.0)})
    EXPECT_LT(reference::referenceIrradiance(*scene, lighting, {at, {0, 0, 1}}, settings).parts[reference::kRefLocalLights].mean.g, 0.01 * floor);
}

// The Cornell world's emissive ceiling quad becomes 8 point lights 1 cm under the box's roof
// (worlds/gltf). The index cells at their height straddle the roof and name the probes standing on
// the roof's top, 1.5 m over it, which see nothing of them; the runtime walks such a column down
// to a probe that does not stand on a surface above the light. Before, every share of the 8
// lights (83 % of the world's local light) went to the roof's top (docs/runtime.md, "Local
// lights"), which the path tracer does not light at all.
TEST(LocalLights, TheCornellBoxsCeilingLightsLendNoLightToTheProbesOnItsRoof) {
  auto w = worlds::loadWorld(DRTV_SOURCE_DIR "/tests/reference/data/cornell_world.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  const BakedWorld baked = bakeWorld(*w, baker::Quality::kDraft);
  ASSERT_FALSE(baked.sectors.empty());
  constexpr double kRoofZ = 10.99;  // the box's ceiling (the quad's lights hang at 10.95)
  auto rt = relit(baked, 22.0, {0, 0, 2}, runtime::RuntimeOptions{});
  int ceiling_lights = 0;
  for (const PointLight& light : baked.manifest.lights) {
    if (light.position.z < kRoofZ - 0.1) continue;  // the world's lamp, 8 m up
    ++ceiling_lights;
    float above = 0.f, below = 0.f;
    for (const runtime::LightShare& sh : rt->cache().distributeLights(std::span(&light, 1)))
      (rt->cache().worldPosition(sh.probe).z > kRoofZ ? above : below) += sh.colour.g;
    EXPECT_GT(below, 0.f) << light.name << ": its light goes into the box";
    EXPECT_EQ(above, 0.f) << light.name << ": and none onto the roof";
  }
  EXPECT_EQ(ceiling_lights, 8);

  // The path tracer: the roof's top gets nothing of the local lights, the box's floor plenty.
  auto scene = reference::ReferenceScene::build(*w, "cornell_world.json");
  ASSERT_TRUE(scene);
  reference::ReferenceLighting lighting{w->sky, 22.0, baked.manifest.lights};  // the lamp and the quad's 8
  reference::ReferenceSettings settings;
  settings.samples = 256;
  const double floor =
      reference::referenceIrradiance(*scene, lighting, {{-3.5, -4.0, 0.01}, {0, 0, 1}}, settings).parts[reference::kRefLocalLights].mean.g;
  EXPECT_GT(floor, 0.1);
  EXPECT_LT(reference::referenceIrradiance(*scene, lighting, {{2.0, -2.0, 11.1}, {0, 0, 1}}, settings).parts[reference::kRefLocalLights].mean.g,
            0.01 * floor);
}

// A lamp hung 6 m over open ground: the bake lit its source probes 1.5 m over the ground, where the
// same lamp would put 16x the irradiance under it. What the runtime gives an object's underside
// 1 m over the ground (facing it: it sees the lit ground and nothing else of the lamp's light)
// against the path tracer, under the lamp and 4 and 8 m beside it.
TEST(LocalLights, ALampHungHighLightsTheGroundBelowItAsThePathTracerDoes) {
  worlds::World w = baker::test::planeWorld(64.0, {0.5f, 0.5f, 0.5f});
  w.name = "lamp over ground";
  w.lights.push_back({"lamp", {32.0, 32.0, 6.0}, glm::vec3(40.f), 16.f});
  w.effects |= kEffectLocalLights;
  const BakedWorld baked = bakeWorld(w, baker::Quality::kDraft);
  ASSERT_FALSE(baked.sectors.empty());
  runtime::RuntimeOptions o;
  o.effects = baked.manifest.effects;
  o.representation = baked.manifest.representation;
  o.components = runtime::kComponentLocalLights;
  o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(baked.sectors.size()));
  runtime::Runtime rt(o);
  ASSERT_TRUE(rt.setLighting(baked.manifest.sky, baked.manifest.lights, baked.manifest.interiors).has_value());
  ASSERT_TRUE(rt.setTime(23.0).has_value());
  for (const Sector& sec : baked.sectors) ASSERT_TRUE(rt.addSector(sec).has_value());
  rt.update({32, 32, 2});
  rt.update({32, 32, 2});  // a blurred refill publishes one update late (publish.h)

  auto scene = reference::ReferenceScene::build(w, "lamp over ground");
  ASSERT_TRUE(scene);
  reference::ReferenceLighting lighting{w.sky, 23.0, w.lights};
  reference::ReferenceSettings settings;
  settings.samples = 1024;
  const glm::vec3 down(0, 0, -1);
  double sum_ref = 0.0, sum_err = 0.0;
  for (const double dx : {0.0, 4.0, 8.0}) {
    const glm::dvec3 at(32.0 + dx, 31.0, 1.0);
    const double ref = reference::referenceIrradiance(*scene, lighting, {at, down}, settings).parts[reference::kRefLocalLights].mean.g;
    const double got = rt.ambient(at, down).irradiance.g;
    std::printf("%.0f m beside the lamp: runtime %.4f, reference %.4f\n", dx, got, ref);
    sum_ref += ref;
    sum_err += std::fabs(got - ref);
  }
  // Measured 0.43 with the footprint factor (probe_cache.cpp kLightFootprintM); 1.19 without it
  // (the share kept whole on a source 1.5 m up: 1.4-3.7x too bright), 0.72 with a 2 m footprint.
  EXPECT_LT(sum_err, kHungLampTolerance * sum_ref);
}

// TheLampsLightInAClosedRoomCarriesTheBakesBounces. Until 2026-12-06 the lamp's light was put on
// the room's one probe, 1.4 m from it, and the point read 3.81 / 4.87 / 5.48 with 1 / 2 / 3
// bounces against the reference's 5.02: right by luck, since that probe (1.5 m up, 1 m under the
// lamp) truly reads 10.68. With the lamp on its own source (placement.h, step 7) the probe read
// 7.24 / 8.32 / 9.43 against its 10.68, and the point, reading it, +66 %: a room with one probe.
// With the 2 m spacing in enclosed spaces the room has 15 probes and the fine level blends those
// that see the point: 2.69 / 3.59 / 4.21 (2 bounces −28 %). What is left is the bounces the bake
// leaves out of a closed room of albedo 0.7 (each adds ~0.6-0.9 here) and LPRT's 1 m clamp of
// 1/d^2 (transfer.h kLprtMinDistance2) under a roof 0.5 m over the lamp: both only darken.
constexpr double kOneBounceAtMost = 0.8, kTwoBouncesAtLeast = 0.65;
// In the closed white room most of the lamp's light on an object's top reaches it after two
// bounces or more (walls and roof of albedo 0.7 all round). The local-light term at a point 1 m
// over the floor, facing up (it sees the roof, lit by the floor's bounce), with the bake's bounces
// against the path tracer's (all of them).
TEST(LocalLights, TheLampsLightInAClosedRoomCarriesTheBakesBounces) {
  const worlds::World w = closedRoomWithLamp();
  auto scene = reference::ReferenceScene::build(w, "closed room");
  ASSERT_TRUE(scene);
  reference::ReferenceLighting lighting{w.sky, 23.0, w.lights};
  reference::ReferenceSettings settings;
  settings.samples = 4096;
  const glm::dvec3 at(31.0, 31.0, 1.0);
  const glm::vec3 up(0, 0, 1);
  const double ref = reference::referenceIrradiance(*scene, lighting, {at, up}, settings).parts[reference::kRefLocalLights].mean.g;
  double last = 0.0;
  for (const int bounces : {1, 2, 3}) {
    baker::BakeSettings bs = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
    bs.transfer.bounces = bounces;
    auto b = baker::bakeInMemory(w, w.name, bs, std::nullopt);
    ASSERT_TRUE(b.has_value());
    ASSERT_EQ(b->manifest.interiors.size(), 1u) << "the closed room is found (rooms.h)";
    runtime::RuntimeOptions o;
    o.effects = b->manifest.effects;
    o.representation = b->manifest.representation;
    o.components = runtime::kComponentLocalLights;
    o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(b->sectors.size()));
    runtime::Runtime rt(o);
    ASSERT_TRUE(rt.setLighting(b->manifest.sky, b->manifest.lights, b->manifest.interiors).has_value());
    ASSERT_TRUE(rt.setTime(23.0).has_value());
    for (const Sector& sec : b->sectors) ASSERT_TRUE(rt.addSector(sec).has_value());
    rt.update({32, 32, 2});
    rt.update({32, 32, 2});
    const runtime::AmbientSample a = rt.ambient(at, up);
    const double got = a.irradiance.g;
    std::printf("bounces %d: runtime %.4f (fine level's weight %.2f), reference %.4f\n", bounces, got, a.fine_weight, ref);
    EXPECT_GT(got, last) << "each bounce adds light";
    EXPECT_LT(got, ref) << "and the bounces the bake leaves out only darken";
    if (bounces == 1) {
      EXPECT_LT(got, kOneBounceAtMost * ref) << "one bounce (LPRT before 2026-12-02) misses half the light here";
    } else if (bounces == 2) {
      EXPECT_GT(got, kTwoBouncesAtLeast * ref) << "the default bake";
    }
    last = got;
  }
}

// The runtime's lamp light at the points the reference gives nothing (above): the ground outside
// the walls reads none of it (index cells under the ground take the cell above them, index_grid.h),
// and the roof's top none, with the facing lookup (sampleVolumeFacing) and with the shaders'
// trilinear filter. The filter reads the 4 m texels that straddle the roof; until 2026-12-03 the
// one under it held the room's light (roof top 2.05 against the floor's 4.87). The room is now
// found at bake time (baker/rooms.h), and a cell inside an interior fills the volume from the
// cell above it (ProbeCache::setInteriorBoxes): 0.018, the ground's.
TEST(LocalLights, TheRuntimeKeepsAClosedRoomsLampInsideItsWalls) {
  const worlds::World w = closedRoomWithLamp();
  const BakedWorld baked = bakeWorld(w, baker::Quality::kDraft);
  ASSERT_FALSE(baked.sectors.empty());
  const glm::vec3 up(0, 0, 1);
  for (const auto lookup : {runtime::RuntimeOptions::VolumeLookup::kTrilinear, runtime::RuntimeOptions::VolumeLookup::kFacing}) {
    runtime::RuntimeOptions o;
    o.volume_lookup = lookup;
    o.components = runtime::kComponentLocalLights;
    auto rt = relit(baked, 23.0, {32, 32, 2}, o);
    rt->update({32, 32, 2});  // a blurred refill publishes one update late (publish.h)
    const float floor = rt->ambient({31.0, 31.0, 0.02}, up).irradiance.g;
    const float ground = rt->ambient({40.0, 31.0, 0.02}, up).irradiance.g;
    const float roof = rt->ambient({31.0, 31.0, 3.32}, up).irradiance.g;
    const char* name = lookup == runtime::RuntimeOptions::VolumeLookup::kFacing ? "facing" : "trilinear";
    std::printf("%s: floor %.4f, ground outside %.4f, roof top %.4f\n", name, floor, ground, roof);
    EXPECT_GT(floor, 0.1f) << name;
    EXPECT_LT(ground, 0.01f * floor) << name;
    EXPECT_LT(roof, 0.01f * floor) << name;
  }
}

}  // namespace
}  // namespace drtv::testing

namespace drtv::testing {
namespace {

// A runtime over every sector of an in-memory bake, lit by its sky at `hour` (no lights), with
// the parts in `components`, the volume filled around `camera` and read with `lookup`.
std::unique_ptr<runtime::Runtime> skyLit(const baker::InMemoryBake& b, uint32_t components, double hour, const glm::dvec3& camera,
                                         runtime::RuntimeOptions::VolumeLookup lookup = runtime::RuntimeOptions::VolumeLookup::kTrilinear) {
  runtime::RuntimeOptions o = runtime::optionsForEffects(b.manifest.effects);
  o.representation = b.manifest.representation;
  o.components = components;
  o.volume_lookup = lookup;
  o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(b.sectors.size()));
  auto rt = std::make_unique<runtime::Runtime>(o);
  EXPECT_TRUE(rt->setLighting(b.manifest.sky, {}, b.manifest.interiors).has_value());
  EXPECT_TRUE(rt->setTime(hour).has_value());
  for (const Sector& sec : b.sectors) EXPECT_TRUE(rt->addSector(sec).has_value());
  rt->update(camera);
  rt->update(camera);  // a blurred refill publishes one update late (publish.h)
  return rt;
}

// Physics' exact answer: a closed room without a window sees no sky and no sun, so at noon the
// sky's and the sun's parts of its floor's ambient are 0 (the path tracer's too, asserted), while
// the ground outside reads the noon sky. The direct sky is 0 in the bake too, and so are the
// bounces: the surface cache (transfer.h) keys a cell by a cube of surfel_cell_m (3 m at draft)
// and a normal direction, and the floor inside the 0.4 m walls lies in the same cubes as the
// sunlit ground outside; since 2026-12-03 such a cell splits by the walls' sides
// (TransferSettings::cell_sides). Shared, as before (`drtv bake --cache-cells shared`), the floor
// read sun bounce 0.020 and sky bounce 0.0054 (green): 2.7 % of the ground's ambient.
TEST(ClosedRoom, ItsFloorReadsNoSkyAndNoSunAtNoon) {
  const worlds::World w = closedRoomWithLamp();
  auto scene = reference::ReferenceScene::build(w, "closed room");
  ASSERT_TRUE(scene);
  reference::ReferenceSettings rs;
  rs.samples = 256;
  const glm::dvec3 floor(31.0, 31.0, 0.02), ground(44.0, 31.0, 0.02);
  const glm::vec3 up(0, 0, 1);
  const reference::ReferenceLighting noon{w.sky, 12.0, {}};
  const auto ref = reference::referenceIrradiance(*scene, noon, {floor, up}, rs);
  for (const int part : {reference::kRefDirectSky, reference::kRefSkyBounce, reference::kRefSunBounce})
    EXPECT_EQ(glm::dvec3(ref.parts[size_t(part)].mean), glm::dvec3(0.0)) << "the path tracer: no path leaves the room";

  for (const bool sides : {true, false}) {
    baker::BakeSettings bs = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
    bs.transfer.cell_sides = sides;
    if (!sides) {
      // The leak shown with the room's one probe of the placement before 2026-12-06: with the 2 m
      // spacing in enclosed spaces (placement.h) the floor's point reads probes whose shared cells
      // gave it nothing (0 measured), which hides what the sides are for.
      bs.placement.setEnclosedSpacing(0.0);
    }
    auto b = baker::bakeInMemory(w, w.name, bs, std::nullopt, 2);
    ASSERT_TRUE(b.has_value());
    ASSERT_EQ(b->manifest.interiors.size(), 1u) << "the room is found (baker/rooms.h)";
    auto at = [&](uint32_t components, const glm::dvec3& p) {
      const glm::vec3 e = skyLit(*b, components, 12.0, {32, 32, 2})->ambient(p, up).irradiance;
      return e.r + e.g + e.b;
    };
    const uint32_t all = runtime::kComponentDirectSky | runtime::kComponentSkyBounce | runtime::kComponentSunBounce;
    const float outside = at(all, ground), inside = at(all, floor), direct = at(runtime::kComponentDirectSky, floor);
    std::printf("noon, cache cells %s: floor inside %.5f (direct sky %.5f), ground outside %.4f\n", sides ? "sides" : "shared",
                inside, direct, outside);
    EXPECT_GT(outside, 0.5f) << "the ground outside sees the noon sky";
    EXPECT_EQ(direct, 0.f) << "no sky is seen inside";
    if (sides)
      EXPECT_EQ(inside, 0.f) << "no light through the walls";
    else
      EXPECT_GT(inside, 0.01f * outside) << "shared cells leak the ground's light in (what the sides are for)";
  }
}

// The outer faces of a house's walls read the volume, whose texels inside its rooms hold no light
// of their own (the rooms' points read their designated probes): an index cell inside fills them
// from the nearest cell outside at its height, the air beside the walls. Until 2026-12-03 such a
// cell took the first cell above the house, the air over its roof, which sees the whole sky: the
// walls' faces read too bright. The two-storey house (its rooms found at bake time; 4 m cells
// with centres inside reach its walls) at 10:00, sun and sky, 20 points on the faces' middles of
// both storeys, summed against the path tracer: +13.0 % with the cell above, +8.0 % after it.
// +10.4 % since 2026-12-07: a covered probe is no longer lifted onto the roof (placement.h,
// covered_stays_under), so the roof keeps an open probe of its own at 7.9 m, which sees the whole
// sky, and the cells over the upper storey's north wall now name it (0.80 -> 1.00 shaded at
// (-2, 6, 6)) where they named a ground probe 8 m out. The bound is 12 %: the cell above reads 13 %.
TEST(ClosedRoom, TheWallsOuterFacesReadTheAirBesideThem) {
  auto w = worlds::loadWorld(DRTV_SOURCE_DIR "/tests/reference/data/two_storey.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  auto scene = reference::ReferenceScene::build(*w, "two storeys");
  ASSERT_TRUE(scene);
  reference::ReferenceSettings rs;
  rs.samples = 1024;
  const reference::ReferenceLighting ten{w->sky, 10.0, {}};
  struct Face {
    glm::dvec3 at;
    glm::vec3 normal;
  };
  std::vector<Face> faces;
  for (const double z : {1.5, 4.5}) {
    for (const double y : {-2.0, 2.0}) {
      faces.push_back({{-6.22, y, z}, {-1, 0, 0}});
      faces.push_back({{6.22, y, z}, {1, 0, 0}});
    }
    for (const double x : {-5.0, 0.0, 5.0}) {
      faces.push_back({{x, -4.22, z}, {0, -1, 0}});
      faces.push_back({{x, 4.22, z}, {0, 1, 0}});
    }
  }
  auto b = baker::bakeInMemory(*w, w->name, baker::BakeSettings::forQuality(baker::Quality::kDraft, 1), std::nullopt, 2);
  ASSERT_TRUE(b.has_value());
  ASSERT_EQ(b->manifest.interiors.size(), 3u) << "the three rooms are found (baker/rooms.h)";
  const auto rt = skyLit(*b, runtime::kComponentDirectSky | runtime::kComponentSkyBounce | runtime::kComponentSunBounce, 10.0, {0, 0, 2});
  double got = 0.0, ref = 0.0;
  for (size_t i = 0; i < faces.size(); ++i) {
    const glm::vec3 e = rt->ambient(faces[i].at, faces[i].normal).irradiance;
    const auto r = reference::referenceIrradiance(*scene, ten, {faces[i].at, faces[i].normal, i}, rs);
    got += e.r + e.g + e.b;
    ref += r.ambient.mean.r + r.ambient.mean.g + r.ambient.mean.b;
  }
  std::printf("%zu outer faces: runtime %.4f against %.4f (%+.1f %%)\n", faces.size(), got, ref, 100.0 * (got / ref - 1.0));
  EXPECT_NEAR(got, ref, 0.12 * ref);
}

// The roof's top sees the whole sky, as the ground does. The volume's 4 m texels straddle a roof
// at 4 m, and the trilinear filter reads the one under it, which the room's covered probes fill
// (living_room's roof read 25 % dark so, docs/accuracy.md). sampleVolumeSided leaves out the
// texels behind the roof that hold covered probes. A room open to the south (no room is found,
// so no interior fills its texels from above) under a 0.3 m roof whose top is at 4 m, at 10:00,
// sun and sky, 6 points on the roof's top against the path tracer.
TEST(ClosedRoom, TheRoofsTopReadsTheSkyAboveItWithTheSidedLookup) {
  worlds::World w = baker::test::planeWorld(64.0, {0.4f, 0.4f, 0.4f});
  w.name = "open room";
  baker::test::addWalledRoom(w, {24.f, 26.f}, {40.f, 38.f}, 3.7f, 0.3f, 0.3f, {0.7f, 0.7f, 0.7f}, false);
  auto scene = reference::ReferenceScene::build(w, w.name);
  ASSERT_TRUE(scene);
  reference::ReferenceSettings rs;
  rs.samples = 1024;
  const reference::ReferenceLighting ten{w.sky, 10.0, {}};
  auto b = baker::bakeInMemory(w, w.name, baker::BakeSettings::forQuality(baker::Quality::kDraft, 1), std::nullopt, 2);
  ASSERT_TRUE(b.has_value());
  ASSERT_TRUE(b->manifest.interiors.empty()) << "open to the south: no room found";
  const glm::vec3 up(0, 0, 1);
  std::vector<glm::dvec3> roof;
  for (const double x : {27.0, 32.0, 37.0})
    for (const double y : {29.0, 35.0}) roof.push_back({x, y, 4.02});
  double ref = 0.0;
  for (size_t i = 0; i < roof.size(); ++i) {
    const auto r = reference::referenceIrradiance(*scene, ten, {roof[i], up, i}, rs);
    ref += r.ambient.mean.r + r.ambient.mean.g + r.ambient.mean.b;
  }
  const uint32_t all = runtime::kComponentDirectSky | runtime::kComponentSkyBounce | runtime::kComponentSunBounce;
  double got[3] = {};
  for (const auto lookup : {runtime::RuntimeOptions::VolumeLookup::kTrilinear, runtime::RuntimeOptions::VolumeLookup::kFacing,
                            runtime::RuntimeOptions::VolumeLookup::kSided}) {
    const auto rt = skyLit(*b, all, 10.0, {32, 32, 2}, lookup);
    for (const glm::dvec3& p : roof) {
      const glm::vec3 e = rt->ambient(p, up).irradiance;
      got[int(lookup)] += e.r + e.g + e.b;
    }
  }
  std::printf("roof top, %zu points: path tracer %.4f; trilinear %.4f (%+.1f %%), facing %.4f (%+.1f %%), sided %.4f (%+.1f %%)\n",
              roof.size(), ref, got[0], 100.0 * (got[0] / ref - 1.0), got[1], 100.0 * (got[1] / ref - 1.0), got[2],
              100.0 * (got[2] / ref - 1.0));
  EXPECT_NEAR(got[2], ref, 0.08 * ref) << "the sided lookup reads the open probes over the roof";
  EXPECT_LT(std::abs(got[2] - ref), std::abs(got[0] - ref)) << "nearer the truth than the trilinear filter";
}

}  // namespace
}  // namespace drtv::testing

namespace drtv::testing {
namespace {

// Two closed rooms side by side under one roof, parted by a 0.2 m wall, a lamp in the west one
// (issue 35). At night the east room gets no light at all (it is closed: physics' answer is 0).
// The fine level reads the probes under the roof that see a point (visibility.h): at the east
// room's floor and on its face of the wall, a few decimetres from the lit room, it must read none of
// the lamp's light, and in the west room it must read it.
worlds::World twoRoomsOneLamp() {
  worlds::World w = baker::test::planeWorld(64.0, {0.4f, 0.4f, 0.4f});
  w.name = "two rooms";
  const glm::vec3 a(0.7f, 0.7f, 0.7f);
  const auto k = worlds::InstanceClass::kStatic;
  const float y0 = 28.f, y1 = 36.f, h = 3.f, t = 0.3f;
  baker::test::addWalledRoom(w, {24.f, y0}, {40.f, y1}, h, t, t, a);
  add(w, box({31.9f, y0 + t, 0}, {32.1f, y1 - t, h}, a, "parting wall"), k);
  w.lights.push_back({"lamp", {28.0, 32.0, 2.2}, glm::vec3(40.f), 12.f});
  w.effects |= kEffectLocalLights;
  return w;
}

TEST(FineLevel, NeverTakesALampsLightThroughAWall) {
  const worlds::World world = twoRoomsOneLamp();
  baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
  settings.placement.covered_column_spacing_m = 2.0;  // probes every 2 m under the roof
  settings.placement.covered_min_horizontal_m = 1.4;
  auto made = baker::bakeInMemory(world, world.name, settings);
  ASSERT_TRUE(made.has_value()) << made.error().message;
  const BakedWorld baked{std::move(made->sectors), std::move(made->manifest)};
  size_t covered = 0;
  for (const Sector& s : baked.sectors) covered += coveredProbes(s);
  ASSERT_GE(covered, 16u) << "probes under the roof in each room";  // (2 m / 2 m keeps every other one: 10)
  runtime::RuntimeOptions o;
  o.components = runtime::kComponentLocalLights;
  auto rt = relit(baked, 23.0, {32, 32, 2}, o);
  rt->update({32, 32, 2});
  const glm::vec3 up(0, 0, 1), east(1, 0, 0);
  // The lit room: its floor reads the fine level, and light.
  const runtime::FineSample lit = rt->cache().fineLookup({28.0, 31.0, 0.02}, up, o.fine);
  EXPECT_GT(lit.weight, 0.5f);
  EXPECT_GT(lit.colours[0].g + lit.colours[3].g, 0.1f) << "the lamp's room is lit";
  // The dark room, at its floor (covered) and on its face of the parting wall (covered or left to
  // the far field): dark.
  for (const auto& [at, n] : {std::pair{glm::dvec3(32.6, 31.0, 0.02), up}, std::pair{glm::dvec3(33.0, 33.0, 0.02), up},
                              std::pair{glm::dvec3(32.1, 32.0, 1.5), east}, std::pair{glm::dvec3(32.1, 29.0, 2.5), east}}) {
    // A probe of the lit room stands within the fine level's reach: only its visibility map keeps it out.
    bool lit_probe_in_reach = false;
    for (int sl = 0; sl < rt->cache().maxSectors(); ++sl)
      if (rt->cache().slotUsed(sl))
        for (int i = 0; i < rt->cache().slot(sl).probe_count; ++i) {
          const glm::dvec3 q = rt->cache().worldPosition({sl, i});
          lit_probe_in_reach |= (rt->cache().flags({sl, i}) & kProbeCovered) && q.x < 31.9 &&
                                glm::length(q - (at + glm::dvec3(n) * double(o.fine.normal_bias_m))) < 0.8 * o.fine.radius_m;
        }
    EXPECT_TRUE(lit_probe_in_reach) << at.x << ", " << at.y << ", " << at.z;
    const runtime::FineSample f = rt->cache().fineLookup(at, n, o.fine);
    if (n == up) {
      EXPECT_GT(f.weight, 0.f) << at.x << ", " << at.y << ": a probe of the dark room sees its floor";
    }
    const glm::vec3 e = runtime::shade(rt->options().representation, f.colours, n);
    EXPECT_LT(e.g, 1e-3f * (lit.colours[0].g + lit.colours[3].g)) << at.x << ", " << at.y << ", " << at.z;
    EXPECT_LT(rt->ambient(at, n).irradiance.g, 0.02f * rt->ambient({28.0, 31.0, 0.02}, up).irradiance.g) << at.x << ", " << at.z;
  }
}

}  // namespace
}  // namespace drtv::testing

namespace drtv::testing {
namespace {

// A closed room with a window onto the open ground (issue 35). Its probes see the ground outside
// through the window; that ground is in the open, lit by the whole sky, and the room's probes hold
// the room's dimmer light. With the visibility maps ended at the covered air's openings
// (BakeSettings::visibility_openings) the fine level leaves the ground outside to the far field and
// still reads the room's floor by the window; without, it blends the room's light onto the ground.
TEST(FineLevel, ARoomsProbesStopAtItsWindow) {
  worlds::World w = baker::test::planeWorld(64.0, {0.4f, 0.4f, 0.4f});
  w.name = "room with a window";
  const glm::vec3 a(0.7f, 0.7f, 0.7f);
  const auto k = worlds::InstanceClass::kStatic;
  const float x0 = 24.f, x1 = 34.f, y0 = 28.f, y1 = 36.f, h = 3.f, t = 0.3f;
  baker::test::addWalledRoom(w, {x0, y0}, {x1, y1}, h, t, t, a, /*south=*/false);
  // The south wall, a window 4 m wide from 0.4 to 2.5 m.
  add(w, box({x0 + t, y0, 0}, {27.f, y0 + t, h}, a, "south wall west"), k);
  add(w, box({31.f, y0, 0}, {x1 - t, y0 + t, h}, a, "south wall east"), k);
  add(w, box({27.f, y0, 0}, {31.f, y0 + t, 0.4f}, a, "sill"), k);
  add(w, box({27.f, y0, 2.5f}, {31.f, y0 + t, h}, a, "lintel"), k);
  const glm::vec3 up(0, 0, 1);
  const glm::dvec3 outside(29.0, 27.0, 0.02), by_window(29.0, 29.0, 0.02);
  float outside_weight[2] = {0, 0};
  for (const bool openings : {true, false}) {
    baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDraft, 1);
    settings.visibility_openings = openings;
    auto made = baker::bakeInMemory(w, w.name, settings);
    ASSERT_TRUE(made.has_value()) << made.error().message;
    const BakedWorld baked{std::move(made->sectors), std::move(made->manifest)};
    auto rt = relit(baked, 12.0, {29, 29, 2});
    const runtime::FineOptions fine = rt->options().fine;
    // A covered probe sees the ground outside through the window, within the fine level's reach.
    bool seen_through_window = false;
    for (int sl = 0; sl < rt->cache().maxSectors(); ++sl)
      if (rt->cache().slotUsed(sl))
        for (int i = 0; i < rt->cache().slot(sl).probe_count; ++i) {
          const glm::dvec3 q = rt->cache().worldPosition({sl, i});
          const glm::dvec3 at = outside + glm::dvec3(up) * double(fine.normal_bias_m);
          seen_through_window |= (rt->cache().flags({sl, i}) & kProbeCovered) && glm::length(q - at) < 0.9 * fine.radius_m && q.y > y0 + t;
        }
    EXPECT_TRUE(seen_through_window) << "a room's probe within reach of the ground outside";
    outside_weight[openings ? 0 : 1] = rt->cache().fineLookup(outside, up, fine).weight;
    EXPECT_GT(rt->cache().fineLookup(by_window, up, fine).weight, 0.5f) << "the room's floor by the window is the fine level's";
  }
  EXPECT_EQ(outside_weight[0], 0.f) << "with openings, the ground outside is the far field's";
  EXPECT_GT(outside_weight[1], 0.f) << "the fault: without them, the room's probes light the ground outside";
}

}  // namespace
}  // namespace drtv::testing
