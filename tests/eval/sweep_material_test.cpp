// The sweep's material grids (eval/techniques/sweep/sweep_material.h) of double-sided geometry: a
// double-sided sheet is a surface from both sides (docs/world-format.md, "Materials"), so the air
// between two is air. Taken as one-sided, a sheet facing the rays' start opened an "inside" that
// ran on to the next hit (the Cornell box's single-sheet walls face each other that way).
#include <gtest/gtest.h>

#include "../../eval/techniques/sweep/sweep_material.h"
#include "../reference/test_scenes.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {
namespace {

// Flat terrain over sector (0, 0) and two vertical sheets at x = 20 and 40 m, y 16..48, z 0..10,
// both wound to face -x (towards the rays that start at x = 0), as a single-sheet room's two
// opposite walls would face each other's way round: a ray meets the first one's front face.
worlds::World sheetWorld(bool double_sided) {
  worlds::World w = testing::planeWorld(64.0, glm::vec3(0.3f), {32.0, 32.0, 0.0});  // the ground over sector (0, 0)
  w.name = "sheet";
  worlds::Mesh sheet;
  sheet.positions = {{20, 16, 0}, {20, 48, 0}, {20, 48, 10}, {20, 16, 10}, {40, 16, 0}, {40, 48, 0}, {40, 48, 10}, {40, 16, 10}};
  sheet.indices = {0, 2, 1, 0, 3, 2, 4, 6, 5, 4, 7, 6};  // (b - a) x (c - a) points to -x
  sheet.albedo = glm::vec3(0.7f);
  sheet.double_sided = double_sided;
  sheet.name = "sheet";
  w.meshes.push_back(sheet);
  w.instances.push_back({1, glm::dmat4(1.0), worlds::InstanceClass::kStatic, "sheet"});
  w.effects = worlds::defaultEffects(w);
  w.effects_explicit = false;
  return w;
}

TEST(SweepMaterial, TheAirBetweenDoubleSidedSheetsIsAir) {
  const worlds::World world = sheetWorld(true);  // the geometry refers to it
  auto g = raytrace::WorldGeometry::build(world, "sheet");
  ASSERT_TRUE(g.has_value()) << g.error().message;
  const sweep::GridShape s{{0.0, 0.0, -2.0}, 1.0, {64, 64, 14}};
  auto m = voxelise(*g, s, {});
  ASSERT_TRUE(m.has_value()) << m.error().message;
  float beyond = 0.f, sheet = 0.f;
  for (int k = 4; k < 10; ++k)  // z 2..8 m: above the ground's cells, below the sheet's top
    for (int j = 20; j < 44; ++j) {
      for (int i = 22; i < 39; ++i) beyond = std::max(beyond, m->density[s.index(i, j, k)]);
      // The sheet lies on the face between cells 19 and 20: whichever of the two its hits land in
      // (a hit at exactly x = 20 m rounds either way, and does differently under AVX2 and AVX-512
      // builds of Embree) is the sheet's.
      sheet = std::max({sheet, m->density[s.index(19, j, k)], m->density[s.index(20, j, k)]});
    }
  EXPECT_LT(beyond, 0.01f) << "the air between double-sided sheets was filled as the inside of a solid";
  EXPECT_GT(sheet, 0.1f) << "the sheet itself blocks its cells";
}

}  // namespace
}  // namespace drtv::eval
