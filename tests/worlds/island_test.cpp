// Tests of the procedural island.
#include <gtest/gtest.h>

#include "drtv/worlds/island.h"
#include "drtv/worlds/summary.h"

namespace drtv::worlds {
namespace {

TEST(Island, SameSeedGivesAnIdenticalWorld) {
  IslandOptions o;
  o.size_km2 = 0.5;
  o.seed = 11;
  const auto a = generateIsland(o), b = generateIsland(o);
  ASSERT_TRUE(a.has_value()) << a.error().message;
  ASSERT_TRUE(b.has_value());
  ASSERT_EQ(a->meshes.size(), b->meshes.size());
  for (size_t m = 0; m < a->meshes.size(); ++m) {
    EXPECT_EQ(a->meshes[m].positions, b->meshes[m].positions);
    EXPECT_EQ(a->meshes[m].indices, b->meshes[m].indices);
    EXPECT_EQ(a->meshes[m].albedo, b->meshes[m].albedo);
  }
  ASSERT_EQ(a->instances.size(), b->instances.size());
  for (size_t i = 0; i < a->instances.size(); ++i) {
    EXPECT_EQ(a->instances[i].transform, b->instances[i].transform);
    EXPECT_EQ(a->instances[i].mesh, b->instances[i].mesh);
    EXPECT_EQ(a->instances[i].cls, b->instances[i].cls);
  }
  ASSERT_EQ(a->interiors.size(), b->interiors.size());
  for (size_t i = 0; i < a->interiors.size(); ++i) EXPECT_EQ(a->interiors[i].probe_position, b->interiors[i].probe_position);
}

TEST(Island, DifferentSeedsGiveDifferentIslands) {
  IslandOptions o;
  o.size_km2 = 0.25;
  o.seed = 1;
  const auto a = generateIsland(o);
  o.seed = 2;
  const auto b = generateIsland(o);
  ASSERT_TRUE(a.has_value() && b.has_value());
  EXPECT_NE(a->meshes[0].positions, b->meshes[0].positions);
}

TEST(Island, OneSquareKilometreIsAboutAKilometreWideWithContent) {
  const auto w = generateIsland(IslandOptions{});
  ASSERT_TRUE(w.has_value()) << w.error().message;
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.max.x - b.min.x, 1000.0, 1.0);
  EXPECT_NEAR(b.max.y - b.min.y, 1000.0, 1.0);
  EXPECT_LT(b.min.z, 0.0);   // the edges lie under the sea
  EXPECT_GT(b.max.z, 10.0);  // hills
  const auto by_class = w->instancesByClass();
  EXPECT_EQ(by_class[size_t(InstanceClass::kTerrain)], 1u);
  // The island covers roughly half of the square; the baker puts ~70 probes per 64 m sector,
  // so aim for several trees and objects per sector of land (~120 land sectors).
  EXPECT_GT(by_class[size_t(InstanceClass::kVegetation)], 1000u);
  EXPECT_GT(by_class[size_t(InstanceClass::kStatic)], 150u);
  EXPECT_GT(w->interiors.size(), 3u);
  // Trees share two meshes: few meshes, many instances.
  EXPECT_LT(w->meshes.size(), 16u);
  EXPECT_TRUE(w->effects & kEffectInteriors);
  EXPECT_TRUE(w->effects & kEffectVolumeBlur);
  EXPECT_FALSE(w->effects & kEffectLocalLights);
}

TEST(Island, InteriorProbesLieInsideTheirVolumes) {
  const auto w = generateIsland(IslandOptions{});
  ASSERT_TRUE(w.has_value());
  for (const InteriorVolume& v : w->interiors) {
    EXPECT_TRUE(glm::all(glm::lessThan(v.min, v.max))) << v.name;
    EXPECT_TRUE(glm::all(glm::lessThanEqual(v.min, v.probe_position))) << v.name;
    EXPECT_TRUE(glm::all(glm::lessThanEqual(v.probe_position, v.max))) << v.name;
  }
}

TEST(Island, SixteenSquareKilometresKeepsTriangleCountsSane) {
  IslandOptions o;
  o.size_km2 = 16;
  const auto w = generateIsland(o);
  ASSERT_TRUE(w.has_value());
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.max.x - b.min.x, 4000.0, 1.0);
  // 4 km at 4 m: 1000 x 1000 cells, 2 triangles each.
  EXPECT_EQ(w->meshes[w->instances[0].mesh].triangleCount(), 2'000'000u);
  EXPECT_LT(w->triangleCount(), 6'000'000u);
}

TEST(Island, RejectsBadOptionsNamingThem) {
  IslandOptions o;
  o.size_km2 = -1;
  const auto a = generateIsland(o);
  ASSERT_FALSE(a.has_value());
  EXPECT_NE(a.error().message.find("size_km2"), std::string::npos);
  o = IslandOptions{};
  o.interior_fraction = 2;
  const auto b = generateIsland(o);
  ASSERT_FALSE(b.has_value());
  EXPECT_NE(b.error().message.find("interior_fraction"), std::string::npos);
}

}  // namespace
}  // namespace drtv::worlds
