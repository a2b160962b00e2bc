// WorldGeometry: bad input is an error or a named skip, never a crash; dynamic never contributes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <glm/gtc/matrix_transform.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/memory_limit.h"
#include "../baker/test_worlds.h"

namespace drtv::raytrace {
namespace {

bool anyNoteContains(const std::vector<std::string>& notes, const std::string& what) {
  for (const auto& n : notes)
    if (n.find(what) != std::string::npos) return true;
  return false;
}

TEST(WorldGeometry, GathersStaticTerrainAndVegetationButNeverDynamic) {
  const worlds::World w = baker::test::smallWorld();
  auto g = raytrace::WorldGeometry::build(w, "small");
  ASSERT_TRUE(g) << g.error().message;
  EXPECT_EQ(g->sectors().count(), 4u) << "a 128 m ground centred on the origin covers 2 x 2 sectors";
  size_t dynamic = 0, vegetation = 0, total = 0;
  for (int32_t y = -1; y <= 0; ++y)
    for (int32_t x = -1; x <= 0; ++x) {
      const raytrace::SectorGeometry s = g->gather({x, y}, 64.0);
      for (uint8_t c : s.cls) {
        dynamic += c == uint8_t(worlds::InstanceClass::kDynamic);
        vegetation += c == uint8_t(worlds::InstanceClass::kVegetation);
      }
      total += s.triangleCount();
    }
  EXPECT_EQ(dynamic, 0u);
  EXPECT_GT(vegetation, 0u);
  EXPECT_GT(total, 0u);
}

TEST(WorldGeometry, BuiltForSomeSectorsItGathersThereExactlyWhatTheWholeBuildGathers) {
  // A terrain large enough to be flattened triangle by triangle, and small instances.
  worlds::World w;
  worlds::Mesh ground;
  ground.name = "ground";
  ground.albedo = glm::vec3(0.3f);
  constexpr int kCells = 100;  // 2 x 100 x 100 triangles, 4 m cells over 400 m
  for (int j = 0; j <= kCells; ++j)
    for (int i = 0; i <= kCells; ++i) ground.positions.emplace_back(-200.f + 4.f * i, -200.f + 4.f * j, 0.1f * float((i * 7 + j * 3) % 5));
  for (int j = 0; j < kCells; ++j)
    for (int i = 0; i < kCells; ++i) {
      const uint32_t a = uint32_t(j * (kCells + 1) + i), b = a + 1, c = a + kCells + 2, d = a + kCells + 1;
      ground.indices.insert(ground.indices.end(), {a, b, c, a, c, d});
    }
  baker::test::add(w, std::move(ground), worlds::InstanceClass::kTerrain);
  for (int k = 0; k < 40; ++k)
    baker::test::add(w, baker::test::box({-190.f + 9.f * k, -150.f + 7.f * k, 0.f}, {-188.f + 9.f * k, -148.f + 7.f * k, 3.f}, glm::vec3(0.4f), "rock"),
              worlds::InstanceClass::kStatic);
  auto whole = raytrace::WorldGeometry::build(w, "w");
  const raytrace::SectorRange only{-1, 0, 0, 1};
  auto part = raytrace::WorldGeometry::build(w, "w", only, 80.0);
  ASSERT_TRUE(whole && part);
  EXPECT_EQ(part->sectors().count(), whole->sectors().count()) << "bounds and sectors are the whole world's";
  EXPECT_EQ(part->triangleCount(), whole->triangleCount());
  EXPECT_EQ(part->fingerprint(), whole->fingerprint());
  for (int32_t y = only.y0; y <= only.y1; ++y)
    for (int32_t x = only.x0; x <= only.x1; ++x)
      for (double halo : {64.0, 80.0}) {
        const raytrace::SectorGeometry a = whole->gather({x, y}, halo), b = part->gather({x, y}, halo);
        ASSERT_GT(a.triangleCount(), 0u);
        EXPECT_EQ(a.vertices, b.vertices) << "sector " << x << "," << y << " halo " << halo;
        EXPECT_EQ(a.cls, b.cls);
        EXPECT_EQ(a.material, b.material);
      }
}

TEST(WorldGeometry, ABakeWhoseGatherCannotFitIsRefusedNamingTheSector) {
  const worlds::World w = baker::test::smallWorld();
  auto g = raytrace::WorldGeometry::build(w, "small.json");
  ASSERT_TRUE(g);
  EXPECT_TRUE(g->checkBakeMemory(g->sectors(), 64.0, 2, "small.json").has_value());
  setMemoryLimit(1000);  // bytes: far below any gather
  const auto r = g->checkBakeMemory(g->sectors(), 64.0, 2, "small.json");
  setMemoryLimit(0);
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().message.rfind("small.json: baking 2 sector(s) at once, each gathering up to ", 0), 0u) << r.error().message;
  EXPECT_NE(r.error().message.find("(--max-memory)"), std::string::npos) << r.error().message;
}

TEST(WorldGeometry, GatherIsInTheSectorsLocalFrame) {
  worlds::World w = baker::test::planeWorld(200.0, glm::vec3(0.5f));
  auto g = raytrace::WorldGeometry::build(w, "plane");
  ASSERT_TRUE(g);
  const raytrace::SectorGeometry s = g->gather({1, -2}, 10.0);
  ASSERT_EQ(s.triangleCount(), 2u);
  // The ground's corner (-200, -200) is at local (-200 - 64, -200 + 128).
  EXPECT_FLOAT_EQ(s.vertices[0].x, -264.f);
  EXPECT_FLOAT_EQ(s.vertices[0].y, -72.f);
}

TEST(WorldGeometry, SkipsNonFiniteAndDegenerateTrianglesWithANote) {
  worlds::World w = baker::test::planeWorld(64.0, glm::vec3(0.5f));
  worlds::Mesh bad = baker::test::box({0, 0, 0}, {1, 1, 1}, glm::vec3(0.5f), "broken box");
  bad.positions[0].x = std::numeric_limits<float>::quiet_NaN();
  bad.positions[7] = bad.positions[6];  // collapses the triangles using both
  baker::test::add(w, bad, worlds::InstanceClass::kStatic);
  auto g = raytrace::WorldGeometry::build(w, "w.json");
  ASSERT_TRUE(g) << g.error().message;
  EXPECT_TRUE(anyNoteContains(g->notes(), "'broken box'") && anyNoteContains(g->notes(), "non-finite"));
  EXPECT_TRUE(anyNoteContains(g->notes(), "degenerate"));
  EXPECT_LT(g->triangleCount(), 2u + 12u);
}

TEST(WorldGeometry, EmptyWorldIsAnErrorNamingTheFile) {
  worlds::World w;
  baker::test::add(w, baker::test::box({0, 0, 0}, {1, 1, 1}, glm::vec3(1.f)), worlds::InstanceClass::kDynamic);
  auto g = raytrace::WorldGeometry::build(w, "empty.json");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("empty.json: nothing to bake"), std::string::npos) << g.error().message;
}

TEST(WorldGeometry, OutOfRangeIndicesAreAnErrorNamingTheMesh) {
  worlds::World w = baker::test::planeWorld(64.0, glm::vec3(0.5f));
  w.meshes[0].indices[2] = 99;
  auto g = raytrace::WorldGeometry::build(w, "w.json");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("mesh 'ground'"), std::string::npos) << g.error().message;
  w = baker::test::planeWorld(64.0, glm::vec3(0.5f));
  w.instances[0].mesh = 5;
  g = raytrace::WorldGeometry::build(w, "w.json");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("w.json: instance 0"), std::string::npos) << g.error().message;
  // A dynamic instance is not baked, but a world naming a missing mesh is bad input all the same
  // (World::validate), not a bounds() abort later.
  w = baker::test::planeWorld(64.0, glm::vec3(0.5f));
  w.instances.push_back(worlds::Instance{7, glm::dmat4(1.0), worlds::InstanceClass::kDynamic, "car"});
  g = raytrace::WorldGeometry::build(w, "w.json");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("instance 1 'car': mesh index 7 out of range"), std::string::npos) << g.error().message;
}

TEST(WorldGeometry, AbsurdSizesAreAnError) {
  worlds::World w = baker::test::planeWorld(1e6, glm::vec3(0.5f));
  auto g = raytrace::WorldGeometry::build(w, "huge.json");
  ASSERT_FALSE(g);
  EXPECT_NE(g.error().message.find("huge.json: geometry spans"), std::string::npos) << g.error().message;
}

TEST(WorldGeometry, GeometryFarFromTheOriginIsAnErrorNotAnOverflow) {
  // A small box 1e12 m out: narrow enough, but its sector keys would not fit in int32.
  for (const glm::dvec3 at : {glm::dvec3(1e12, 0, 0), glm::dvec3(0, -3e7, 0), glm::dvec3(0, 0, 2e6)}) {
    worlds::World w;
    w.name = "far";
    baker::test::add(w, baker::test::box(glm::vec3(0.f), glm::vec3(4.f), glm::vec3(0.5f), "rock"), worlds::InstanceClass::kStatic,
              glm::translate(glm::dmat4(1.0), at));
    auto g = raytrace::WorldGeometry::build(w, "far.json");
    ASSERT_FALSE(g) << at.x << " " << at.y << " " << at.z;
    EXPECT_NE(g.error().message.find("far.json: geometry lies at"), std::string::npos) << g.error().message;
  }
}

TEST(WorldGeometry, SingularOrNonFiniteTransformsAreSkippedWithANote) {
  worlds::World w = baker::test::planeWorld(64.0, glm::vec3(0.5f));
  baker::test::add(w, baker::test::box({0, 0, 0}, {1, 1, 1}, glm::vec3(0.5f), "flat"), worlds::InstanceClass::kStatic, glm::dmat4(0.0));
  glm::dmat4 nan(1.0);
  nan[3][0] = std::numeric_limits<double>::infinity();
  baker::test::add(w, baker::test::box({0, 0, 0}, {1, 1, 1}, glm::vec3(0.5f), "far"), worlds::InstanceClass::kStatic, nan);
  auto g = raytrace::WorldGeometry::build(w, "w.json");
  ASSERT_TRUE(g);
  EXPECT_EQ(g->triangleCount(), 2u);
  EXPECT_EQ(g->notes().size(), 2u);
}

}  // namespace
}  // namespace drtv::raytrace

namespace drtv::raytrace {
namespace {

// A mirroring instance (negative determinant: glTF's scale -1, as in tests/assets/
// probe_room_bevy) keeps its triangles' front side where it was: without the flip the plane faced
// down, every index-grid cell above it read "inside geometry" and the baked ambient was 0.
TEST(WorldGeometry, AMirroredInstanceKeepsItsFrontFaceUp) {
  for (const glm::dvec3 scale : {glm::dvec3(1, 1, 1), glm::dvec3(-1, 1, 1), glm::dvec3(-2, -2, 2)}) {
    worlds::World w = baker::test::planeWorld(100.0, glm::vec3(0.5f));
    w.instances[0].transform = glm::dmat4(glm::dmat3(scale.x, 0, 0, 0, scale.y, 0, 0, 0, scale.z));
    auto g = WorldGeometry::build(w, "mirrored");
    ASSERT_TRUE(g) << g.error().message;
    const SectorGeometry s = g->gather({0, 0}, 64.0);
    auto scene = RayScene::build(s.vertices);
    ASSERT_TRUE(scene);
    ASSERT_GT(scene->triangleCount(), 0u);
    for (uint32_t t = 0; t < scene->triangleCount(); ++t)
      EXPECT_GT(scene->normal(t).z, 0.99f) << "scale (" << scale.x << ", " << scale.y << ", " << scale.z << ") triangle " << t;
  }
}

}  // namespace
}  // namespace drtv::raytrace
