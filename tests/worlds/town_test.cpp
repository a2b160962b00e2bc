// Tests of the procedural town (drtv/worlds/town.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "drtv/worlds/load.h"
#include "drtv/worlds/town.h"

namespace drtv::worlds {
namespace {

TownOptions smallTown(uint64_t seed = 3) {
  TownOptions o;
  o.size_m = 150;
  o.seed = seed;
  o.lit_room_fraction = 0.1;
  return o;
}

// The town's meshes are unions of boxes (24 vertices each, appendBox's layout) and stair
// flights (24 vertices, not axis-aligned); this reads a mesh's boxes back as bounds.
struct Box {
  glm::vec3 lo, hi;
};
std::vector<Box> boxesOf(const Mesh& m) {
  std::vector<Box> out;
  for (size_t v = 0; v + 24 <= m.positions.size(); v += 24) {
    Box b{m.positions[v], m.positions[v]};
    for (size_t k = v; k < v + 24; ++k) b.lo = glm::min(b.lo, m.positions[k]), b.hi = glm::max(b.hi, m.positions[k]);
    out.push_back(b);
  }
  return out;
}

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

TEST(Town, SameSeedGivesAnIdenticalWorldAndAnotherSeedAnother) {
  const auto a = generateTown(smallTown()), b = generateTown(smallTown()), c = generateTown(smallTown(4));
  ASSERT_TRUE(a.has_value()) << a.error().message;
  ASSERT_TRUE(b.has_value() && c.has_value());
  ASSERT_EQ(a->meshes.size(), b->meshes.size());
  for (size_t m = 0; m < a->meshes.size(); ++m) {
    EXPECT_EQ(a->meshes[m].positions, b->meshes[m].positions);
    EXPECT_EQ(a->meshes[m].indices, b->meshes[m].indices);
  }
  ASSERT_EQ(a->lights.size(), b->lights.size());
  for (size_t i = 0; i < a->lights.size(); ++i) EXPECT_EQ(a->lights[i].position, b->lights[i].position);
  bool differs = a->meshes.size() != c->meshes.size();
  for (size_t m = 0; !differs && m < a->meshes.size(); ++m) differs = a->meshes[m].positions != c->meshes[m].positions;
  EXPECT_TRUE(differs);
}

// Storeys 2.8-3.6 m apart, 2-8 of them, in buildings whose slabs are stacked one storey apart:
// read back from the slabs' tops (the plinth's top is the ground floor).
TEST(Town, BuildingsHaveTwoToEightStoreysTwoPointEightToThreePointSixMetresApart) {
  const auto w = generateTown(TownOptions{});
  ASSERT_TRUE(w.has_value()) << w.error().message;
  size_t buildings = 0;
  std::set<size_t> storey_counts;
  for (const Mesh& m : w->meshes) {
    if (!endsWith(m.name, " slabs")) continue;
    ++buildings;
    std::set<int> tops;  // centimetres
    for (const Box& b : boxesOf(m)) tops.insert(int(std::lround(b.hi.z * 100)));
    ASSERT_GE(tops.size(), 3u) << m.name;  // ground floor, at least one floor above, roof
    const std::vector<int> z(tops.begin(), tops.end());
    const int step = z[1] - z[0];
    EXPECT_GE(step, 280) << m.name;
    EXPECT_LE(step, 360) << m.name;
    for (size_t k = 1; k < z.size(); ++k) EXPECT_NEAR(z[k] - z[k - 1], step, 1) << m.name << " level " << k;
    storey_counts.insert(z.size() - 1);
  }
  EXPECT_GT(buildings, 200u);
  EXPECT_EQ(*storey_counts.begin(), 2u);
  EXPECT_EQ(*storey_counts.rbegin(), 8u);
}

// Every lamp hangs in a room: under a slab 0.4 m above it, over a floor one storey below, and
// between the walls of its building (its slab covers it).
TEST(Town, EveryLampHangsUnderACeilingInsideItsBuilding) {
  const auto w = generateTown(smallTown());
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_GT(w->lights.size(), 10u);
  std::vector<Box> slabs;
  for (const Mesh& m : w->meshes)
    if (endsWith(m.name, " slabs"))
      for (const Box& b : boxesOf(m)) slabs.push_back(b);
  for (const PointLight& l : w->lights) {
    const glm::vec3 p(l.position);
    bool ceiling = false, floor = false;
    for (const Box& b : slabs) {
      if (p.x <= b.lo.x || p.x >= b.hi.x || p.y <= b.lo.y || p.y >= b.hi.y) continue;
      ceiling |= std::abs(b.lo.z - (p.z + 0.4f)) < 1e-3f;
      floor |= b.hi.z < p.z - 1.5f && b.hi.z > p.z - 3.6f;
    }
    EXPECT_TRUE(ceiling) << l.name;
    EXPECT_TRUE(floor) << l.name;
  }
}

// Windows and doors are open: a facade of n bays is more than n boxes, and a street door
// reaches the ground floor. Read on one storey of one facade mesh: its boxes' union leaves gaps.
TEST(Town, FacadesHaveOpeningsAndTheGroundFloorADoor) {
  const auto w = generateTown(smallTown());
  ASSERT_TRUE(w.has_value()) << w.error().message;
  size_t facades = 0, with_door = 0;
  for (size_t mi = 0; mi < w->meshes.size(); ++mi) {
    const Mesh& m = w->meshes[mi];
    if (!endsWith(m.name, " facade")) continue;
    ++facades;
    // The slabs mesh of the same building follows the facade; its lowest top is the ground floor.
    const Mesh& slabs = w->meshes[mi + 1];
    ASSERT_TRUE(endsWith(slabs.name, " slabs")) << slabs.name;
    float ground = 1e30f;
    for (const Box& b : boxesOf(slabs)) ground = std::min(ground, b.hi.z);
    // Pieces of the ground floor's walls that start above the floor: sills, lintels; a door is a
    // gap whose lintel starts 2.3 m up with nothing under it: count pieces starting at 2.3 m.
    size_t lintels = 0, sills = 0;
    for (const Box& b : boxesOf(m)) {
      if (std::abs(b.lo.z - (ground + 2.3f)) < 1e-3f && b.hi.z < ground + 4.0f) ++lintels;
      if (std::abs(b.hi.z - (ground + 0.9f)) < 1e-3f) ++sills;
    }
    EXPECT_GT(lintels, 0u) << m.name;
    EXPECT_GT(sills, 0u) << m.name;  // under windows beside the door (or all along, over it)
    with_door += lintels > 0;
  }
  EXPECT_GT(facades, 5u);
  EXPECT_EQ(with_door, facades);
}

TEST(Town, LoadsFromJsonAndRefusesBadOptionsNamingThem) {
  const auto ok = parseWorldJson(R"({"town": {"size_m": 150, "seed": 3}})", ".", "t.json");
  ASSERT_TRUE(ok.has_value()) << ok.error().message;
  EXPECT_GT(ok->triangleCount(), 10000u);
  const std::pair<const char*, const char*> bad[] = {
      {R"({"town": {"size_m": 10}})", "size_m"},
      {R"({"town": {"min_storeys": 5, "max_storeys": 3}})", "max_storeys"},
      {R"({"town": {"min_storeys": 2.5}})", "min_storeys"},
      {R"({"town": {"block_m": 50, "street_m": 30}})", "street_m"},
      {R"({"town": {"courtyard_fraction": 0.6, "pair_fraction": 0.6}})", "square_fraction"},
      {R"({"town": {"lit_room_fraction": 2}})", "lit_room_fraction"},
      {R"({"town": {"storeys": 3}})", "storeys"},
      {R"({"town": {}, "island": {}})", "town"},
  };
  for (const auto& [text, key] : bad) {
    const auto r = parseWorldJson(text, ".", "t.json");
    ASSERT_FALSE(r.has_value()) << text;
    EXPECT_NE(r.error().message.find("t.json"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find(key), std::string::npos) << r.error().message;
  }
}

// 8 km a side is within the documented range, and ~1 G triangles: refused up front, naming the
// key, not an abort in the allocator.
TEST(Town, ATownTooLargeForMemoryIsRefusedBeforeItIsBuilt) {
  const auto r = parseWorldJson(R"({"town": {"size_m": 8192}})", ".", "big.json");
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("big.json: town: key 'size_m'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("needs about"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace drtv::worlds
