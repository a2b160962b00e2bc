// Closed rooms found at bake time (rooms.h, issue 16): which spaces are rooms, where their boxes
// lie, artists' interiors first, one room seen from four sectors, the same rooms on any number of
// threads, and the bake carrying them into its manifest and probes.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "drtv/baker/bake.h"
#include "drtv/baker/rooms.h"
#include "drtv/worlds/island.h"
#include "test_worlds.h"

namespace drtv::baker {
namespace {

using worlds::InstanceClass;

// A box room's inside, to 1 mm: the rays land on planes at float precision.
constexpr double kPlaneTolM = 1e-3;

// A closed room of `wall_m` thick walls and roof, inside [lo, hi] (floor = the ground at lo.z),
// with a window of 2 x 1.2 m in its south wall unless `window` is false, on a ground of 128 m.
struct RoomSpec {
  glm::vec3 lo{-5, -4, 0}, hi{5, 4, 3};
  float wall_m = 0.1f;
  bool window = true;
  bool north_wall = true;
};

worlds::World roomWorld(const RoomSpec& r, const glm::vec3& offset = glm::vec3(0.f)) {
  worlds::World w = test::planeWorld(128.0, {0.3f, 0.3f, 0.3f});
  const glm::vec3 lo = r.lo + offset, hi = r.hi + offset, a(0.7f);
  const float t = r.wall_m;
  test::add(w, test::box({lo.x - t, lo.y - t, lo.z}, {lo.x, hi.y + t, hi.z}, a, "west wall"), InstanceClass::kStatic);
  test::add(w, test::box({hi.x, lo.y - t, lo.z}, {hi.x + t, hi.y + t, hi.z}, a, "east wall"), InstanceClass::kStatic);
  if (r.north_wall) test::add(w, test::box({lo.x, hi.y, lo.z}, {hi.x, hi.y + t, hi.z}, a, "north wall"), InstanceClass::kStatic);
  const float cx = 0.5f * (lo.x + hi.x);
  if (r.window) {
    test::add(w, test::box({lo.x, lo.y - t, lo.z}, {cx - 1, lo.y, hi.z}, a, "south wall left"), InstanceClass::kStatic);
    test::add(w, test::box({cx + 1, lo.y - t, lo.z}, {hi.x, lo.y, hi.z}, a, "south wall right"), InstanceClass::kStatic);
    test::add(w, test::box({cx - 1, lo.y - t, lo.z}, {cx + 1, lo.y, lo.z + 1}, a, "under the window"), InstanceClass::kStatic);
    test::add(w, test::box({cx - 1, lo.y - t, lo.z + 2.2f}, {cx + 1, lo.y, hi.z}, a, "over the window"), InstanceClass::kStatic);
  } else {
    test::add(w, test::box({lo.x, lo.y - t, lo.z}, {hi.x, lo.y, hi.z}, a, "south wall"), InstanceClass::kStatic);
  }
  test::add(w, test::box({lo.x - t, lo.y - t, hi.z}, {hi.x + t, hi.y + t, hi.z + t}, a, "roof"), InstanceClass::kStatic);
  return w;
}

Result<std::vector<InteriorVolume>> rooms(const worlds::World& w, RoomStats* stats = nullptr, RoomSettings s = {}) {
  auto g = raytrace::WorldGeometry::build(w, w.name);
  if (!g) return std::unexpected(g.error());
  return findRooms(*g, g->sectors(), w.interiors, s, stats);
}

TEST(Rooms, AClosedRoomWithAWindowIsFoundWithItsInsideAndHalfItsWalls) {
  const RoomSpec spec;
  RoomStats stats;
  auto found = rooms(roomWorld(spec), &stats);
  ASSERT_TRUE(found.has_value()) << found.error().message;
  ASSERT_EQ(found->size(), 1u);
  const InteriorVolume& r = (*found)[0];
  EXPECT_EQ(r.name, "room 1");
  // The inside, grown through each wall by half its 0.1 m; the floor is a plane (no thickness
  // found within 2 wall margins: the whole margin).
  const double half = 0.5 * spec.wall_m;
  EXPECT_NEAR(r.min.x, spec.lo.x - half, kPlaneTolM);
  EXPECT_NEAR(r.max.x, spec.hi.x + half, kPlaneTolM);
  EXPECT_NEAR(r.min.y, spec.lo.y - half, kPlaneTolM);
  EXPECT_NEAR(r.max.y, spec.hi.y + half, kPlaneTolM);
  EXPECT_NEAR(r.max.z, spec.hi.z + half, kPlaneTolM);
  EXPECT_NEAR(r.min.z, spec.lo.z - RoomSettings{}.wall_margin_m, kPlaneTolM);
  // The designated probe in the middle of the inside; the blend no wider than the thinnest wall's
  // half, so that every inside surface reads the probe whole and no outside one reads it at all.
  EXPECT_NEAR(r.probe_position.x, 0.5 * (spec.lo.x + spec.hi.x), kPlaneTolM);
  EXPECT_NEAR(r.probe_position.y, 0.5 * (spec.lo.y + spec.hi.y), kPlaneTolM);
  EXPECT_NEAR(r.probe_position.z, 0.5 * (spec.lo.z + spec.hi.z), kPlaneTolM);
  EXPECT_LE(r.blend_distance_m, half + kPlaneTolM);
  EXPECT_GT(r.blend_distance_m, 0.f);
  // Seen from the four sectors it straddles (the room is centred on the world's origin).
  EXPECT_GE(stats.dropped_overlap, 1u);
  EXPECT_GT(stats.rays, 0u);
}

TEST(Rooms, AShedOpenOnOneSideIsNoRoom) {
  RoomSpec spec;
  spec.north_wall = false;
  RoomStats stats;
  auto found = rooms(roomWorld(spec), &stats);
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(found->empty());
  EXPECT_GT(stats.seeds, 0u) << "the shed's roof covers air: its seeds were tested and refused";
}

TEST(Rooms, ARoofOnPillarsAndASolidBlockAreNoRooms) {
  worlds::World w = test::planeWorld(128.0, {0.3f, 0.3f, 0.3f});
  for (const glm::vec2 c : {glm::vec2(-4, -4), glm::vec2(4, -4), glm::vec2(-4, 4), glm::vec2(4, 4)})
    test::add(w, test::box({c.x - 0.2f, c.y - 0.2f, 0}, {c.x + 0.2f, c.y + 0.2f, 3}, glm::vec3(0.6f)), InstanceClass::kStatic);
  test::add(w, test::box({-5, -5, 3}, {5, 5, 3.3f}, glm::vec3(0.6f), "roof"), InstanceClass::kStatic);
  test::add(w, test::box({20, 20, -1}, {30, 28, 6}, glm::vec3(0.6f), "block"), InstanceClass::kStatic);
  auto found = rooms(w);
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(found->empty());
}

// A room turned off the axes: its axis-aligned box (InteriorVolume's) would cross its walls and
// lend its probe to the ground outside. Turned by 3 or 30 degrees, the walls cross the faces the
// axis rays found and it is left to the volume. The same room on the axes with a tall cupboard in
// one corner is still a room.
TEST(Rooms, ARoomTurnedOffTheAxesIsLeftToTheVolumeAndACupboardDoesNotHideARoom) {
  const worlds::World straight = roomWorld(RoomSpec{});
  for (const double deg : {3.0, 30.0}) {
    worlds::World turned = test::planeWorld(128.0, {0.3f, 0.3f, 0.3f});
    const glm::dmat4 turn = glm::rotate(glm::dmat4(1.0), glm::radians(deg), glm::dvec3(0, 0, 1));
    for (size_t i = 1; i < straight.instances.size(); ++i)
      test::add(turned, straight.meshes[straight.instances[i].mesh], InstanceClass::kStatic, turn);
    RoomStats stats;
    auto found = rooms(turned, &stats);
    ASSERT_TRUE(found.has_value());
    EXPECT_TRUE(found->empty()) << deg;
    EXPECT_GT(stats.enclosed, 0u) << deg << ": its seeds are enclosed; the box is what is refused";
  }
  worlds::World cupboard = straight;
  test::add(cupboard, test::box({-5, 3.4f, 0}, {-4.4f, 4, 2.9f}, glm::vec3(0.5f), "cupboard"), InstanceClass::kStatic);
  auto with_cupboard = rooms(cupboard);
  ASSERT_TRUE(with_cupboard.has_value());
  EXPECT_EQ(with_cupboard->size(), 1u);
}

TEST(Rooms, AnArtistsInteriorWins) {
  worlds::World w = roomWorld(RoomSpec{});
  w.interiors.push_back({"the artist's", {-4, -3, 0.5}, {4, 3, 2.5}, {0, 0, 1.5}, 1.f});
  RoomStats stats;
  auto found = rooms(w, &stats);
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(found->empty());
  EXPECT_GE(stats.dropped_artist, 1u);
}

TEST(Rooms, TwoRoomsSideBySideAreTwoRoomsThatMeetAtTheirWallsMiddle) {
  RoomSpec west;
  west.lo = {20, 10, 0};
  west.hi = {26, 16, 3};
  west.window = false;
  worlds::World w = roomWorld(west);
  // The east room shares the west room's east wall ([26, 26.1]).
  const worlds::World east = roomWorld(RoomSpec{{26.1f, 10, 0}, {32, 16, 3}, 0.1f, false, true});
  for (size_t i = 1; i < east.instances.size(); ++i)  // its walls and roof, not its ground
    test::add(w, east.meshes[east.instances[i].mesh], InstanceClass::kStatic);
  auto found = rooms(w);
  ASSERT_TRUE(found.has_value());
  ASSERT_EQ(found->size(), 2u);
  const InteriorVolume& a = (*found)[0].min.x < (*found)[1].min.x ? (*found)[0] : (*found)[1];
  const InteriorVolume& b = (*found)[0].min.x < (*found)[1].min.x ? (*found)[1] : (*found)[0];
  EXPECT_NEAR(a.max.x, 26.05, kPlaneTolM);
  EXPECT_NEAR(b.min.x, 26.05, kPlaneTolM);
}

TEST(Rooms, AreTheSameOnOneThreadAndOnTwo) {
  worlds::World w = roomWorld(RoomSpec{});
  const worlds::World other = roomWorld(RoomSpec{{30, 30, 0}, {38, 36, 2.5f}, 0.3f, true, true});
  for (size_t i = 1; i < other.instances.size(); ++i) test::add(w, other.meshes[other.instances[i].mesh], InstanceClass::kStatic);
  std::vector<std::vector<InteriorVolume>> runs;
  for (int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
    auto found = rooms(w);
    ASSERT_TRUE(found.has_value());
    runs.push_back(*found);
  }
  ASSERT_EQ(runs[0].size(), 2u);
  ASSERT_EQ(runs[1].size(), runs[0].size());
  for (size_t i = 0; i < runs[0].size(); ++i) {
    EXPECT_EQ(runs[0][i].name, runs[1][i].name);
    EXPECT_EQ(runs[0][i].min, runs[1][i].min);
    EXPECT_EQ(runs[0][i].max, runs[1][i].max);
    EXPECT_EQ(runs[0][i].probe_position, runs[1][i].probe_position);
    EXPECT_EQ(runs[0][i].blend_distance_m, runs[1][i].blend_distance_m);
  }
}

// Content nobody here tuned the search on: the island generator's hollow buildings (0.4 m walls,
// a 1.4 x 2.2 m door, a roof overhanging 0.3 m, turned by multiples of 90 degrees) come with the
// artist's interior of each room. Without them, the search finds those rooms again: each found
// box is an artist's box grown through the walls by at most the wall margin, and it finds nothing
// else.
TEST(Rooms, FindTheIslandGeneratorsRoomsWithoutItsInteriors) {
  auto island = worlds::generateIsland(worlds::IslandOptions{});
  ASSERT_TRUE(island.has_value());
  const std::vector<InteriorVolume> artist = island->interiors;
  ASSERT_GT(artist.size(), 5u);
  island->interiors.clear();
  RoomStats stats;
  auto found = rooms(*island, &stats);
  ASSERT_TRUE(found.has_value());
  const double margin = RoomSettings{}.wall_margin_m;
  size_t matched = 0;
  for (const InteriorVolume& r : *found) {
    const InteriorVolume* a = nullptr;
    for (const InteriorVolume& c : artist)
      if (glm::all(glm::greaterThan(r.probe_position, c.min)) && glm::all(glm::lessThan(r.probe_position, c.max))) a = &c;
    ASSERT_NE(a, nullptr) << r.name << " at " << r.probe_position.x << ", " << r.probe_position.y << " is no generated room";
    ++matched;
    for (int k = 0; k < 3; ++k) {
      // The generator's box reaches the roof's underside from the floor's top, and so does the
      // found one's inside; the found box grows by up to the margin.
      EXPECT_LE(r.min[k], a->min[k] + kPlaneTolM) << r.name << " axis " << k;
      EXPECT_GE(r.min[k], a->min[k] - margin - kPlaneTolM) << r.name << " axis " << k;
      EXPECT_GE(r.max[k], a->max[k] - kPlaneTolM) << r.name << " axis " << k;
      EXPECT_LE(r.max[k], a->max[k] + margin + kPlaneTolM) << r.name << " axis " << k;
    }
  }
  std::printf("%zu of the generator's %zu rooms found (%zu seeds, %zu enclosed)\n", matched, artist.size(), stats.seeds, stats.enclosed);
  EXPECT_GE(matched, artist.size() * 3 / 4) << "most of them are found";
}

TEST(Rooms, BadSettingsAreRefusedByTheBake) {
  BakeSettings s = BakeSettings::forQuality(Quality::kDraft, 1);
  s.rooms.test_rays = 0;
  ASSERT_FALSE(validateSettings(s));
  EXPECT_NE(validateSettings(s).error().message.find("rooms"), std::string::npos);
  s = BakeSettings::forQuality(Quality::kDraft, 1);
  s.rooms.max_extent_m = 200.0;  // beyond the halo the search gathers
  ASSERT_FALSE(validateSettings(s));
  EXPECT_NE(validateSettings(s).error().message.find("rooms"), std::string::npos);
  s.rooms.enabled = false;
  EXPECT_TRUE(validateSettings(s));
}

// The bake carries the rooms into its manifest (after the artist's interiors), places their
// designated probes and bakes the interiors effect for a world whose effects are derived; off, or
// for a world that names its effects without interiors, it bakes what it baked before.
TEST(Rooms, TheBakeGivesAFoundRoomItsDesignatedProbe) {
  const worlds::World w = roomWorld(RoomSpec{});
  BakeSettings s = BakeSettings::forQuality(Quality::kDraft, 1);
  auto with = bakeInMemory(w, w.name, s, std::nullopt, 2);
  ASSERT_TRUE(with.has_value()) << with.error().message;
  ASSERT_EQ(with->manifest.interiors.size(), 1u);
  EXPECT_TRUE(with->manifest.effects & kEffectInteriors);
  size_t designated = 0;
  for (const Sector& sec : with->sectors)
    for (const ProbeRecord& r : sec.probes) {
      const ProbeData p = unpackProbe(r);
      if ((p.flags & kProbeInterior) && p.interior == 1) ++designated;
    }
  EXPECT_EQ(designated, 1u);

  s.rooms.enabled = false;
  auto without = bakeInMemory(w, w.name, s, std::nullopt, 2);
  ASSERT_TRUE(without.has_value());
  EXPECT_TRUE(without->manifest.interiors.empty());
  EXPECT_FALSE(without->manifest.effects & kEffectInteriors);

  worlds::World named = w;
  named.effects_explicit = true;  // sun, sky, direct sky, distant occlusion: no interiors asked for
  auto explicit_effects = bakeInMemory(named, w.name, BakeSettings::forQuality(Quality::kDraft, 1), std::nullopt, 2);
  ASSERT_TRUE(explicit_effects.has_value());
  EXPECT_TRUE(explicit_effects->manifest.interiors.empty());
}

}  // namespace
}  // namespace drtv::baker
