// The sweep's ground-proximity blend (eval/techniques/sweep/ground_blend.h, seed 001's "additional
// tweak"): at the ground a point reads the ground normal's irradiance whatever its own normal, from
// the blend height up it reads its own, in between a linear mix; the ground map is the terrain's.
#include <cmath>

#include <gtest/gtest.h>

#include "../../eval/techniques/sweep/ground_blend.h"
#include "../reference/test_scenes.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {
namespace {

// A plane z = 5 + 0.1 x + 0.05 y sampled at the centres of 8 x 8 columns of 2 m from (10, 20).
GroundMap tiltedMap() {
  GroundMap g{{10.0, 20.0}, 2.0, 8, 8, {}};
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const double x = g.origin.x + (i + 0.5) * g.cell_m, y = g.origin.y + (j + 0.5) * g.cell_m;
      g.z.push_back(float(5.0 + 0.1 * x + 0.05 * y));
    }
  return g;
}

// Heights are floats of about 7 m: 1e-6 relative.
constexpr double kHeightTolM = 1e-5;

TEST(GroundMap, IsBilinearInItsColumnsAndItsNormalIsThePlanes) {
  const GroundMap g = tiltedMap();
  for (double x : {12.3, 15.0, 20.7})
    for (double y : {22.1, 27.9, 33.3}) EXPECT_NEAR(g.heightAt(x, y), 5.0 + 0.1 * x + 0.05 * y, kHeightTolM) << x << ", " << y;
  const glm::vec3 n = g.normalAt(16.0, 28.0);
  const glm::vec3 want = glm::normalize(glm::vec3(-0.1f, -0.05f, 1.f));
  EXPECT_NEAR(glm::dot(n, want), 1.0, 1e-6);
}

TEST(GroundMap, AColumnWithoutTerrainGivesNoHeight) {
  GroundMap g = tiltedMap();
  g.z[size_t(3) + 8 * 3] = std::nanf("");
  EXPECT_TRUE(std::isnan(g.heightAt(17.5, 27.5)));  // between columns 3 and 4
  EXPECT_FALSE(std::isnan(g.heightAt(25.0, 35.0)));
}

TEST(GroundBlend, AtTheGroundASidewaysNormalReadsTheGroundNormalAndFromTheBlendHeightUpItsOwn) {
  const GroundMap g = tiltedMap();
  const glm::vec3 sun = glm::normalize(glm::vec3(0.3f, -0.2f, 1.f));
  auto e = [&](const glm::vec3& n) { return glm::vec3(std::max(0.f, glm::dot(n, sun))); };
  const glm::vec3 side(-1.f, 0.f, 0.f);
  const double x = 16.0, y = 28.0, h = 5.0 + 0.1 * x + 0.05 * y, b = 2.0;
  const glm::vec3 ground = e(g.normalAt(x, y));
  ASSERT_GT(std::abs(ground.x - e(side).x), 0.1f) << "the case must tell the two normals apart";
  EXPECT_NEAR(blendTowardGround(&g, b, {x, y, h}, side, e).x, ground.x, 1e-6);
  EXPECT_NEAR(blendTowardGround(&g, b, {x, y, h - 3.0}, side, e).x, ground.x, 1e-6);  // below it too
  EXPECT_EQ(blendTowardGround(&g, b, {x, y, h + b}, side, e).x, e(side).x);
  EXPECT_EQ(blendTowardGround(&g, b, {x, y, h + 10.0}, side, e).x, e(side).x);
  EXPECT_NEAR(blendTowardGround(&g, b, {x, y, h + 0.5 * b}, side, e).x, 0.5 * (ground.x + e(side).x), 1e-5);
  EXPECT_EQ(blendTowardGround(&g, 0.0, {x, y, h}, side, e).x, e(side).x) << "blend height 0 is off";
  EXPECT_EQ(blendTowardGround(nullptr, b, {x, y, h}, side, e).x, e(side).x);
}

// Flat ground z = 0 over sector (0, 0), albedo 0.3, under the default sky.
// A 64 m ground quad over sector (0, 0).
worlds::World flatWorld() { return testing::planeWorld(64.0, glm::vec3(0.3f), {32.0, 32.0, 0.0}); }

std::unique_ptr<Technique> preparedSweep(const worlds::World& w, const TechniqueParams& p) {
  auto t = makeTechnique("sweep", p);
  EXPECT_TRUE(t.has_value()) << t.error().message;
  PrepareInput in{w, "flat", {0, 0, 0, 0}, 1, 1, nullptr};
  auto ok = (*t)->prepare(in);
  EXPECT_TRUE(ok.has_value()) << ok.error().message;
  auto lit = (*t)->setLighting(10.0, {});
  EXPECT_TRUE(lit.has_value()) << lit.error().message;
  return std::move(*t);
}

// Through the technique: on flat ground under the open sky a sideways normal at the ground sees
// half sky and half ground, so without the blend it reads less than the ground's up normal; with a
// blend of 2 cells it reads what the up normal reads, and from 2 m above the ground
// exactly what it reads without the blend.
TEST(SweepGroundBlend, OnFlatGroundASidewaysNormalAtTheGroundReadsTheGroundsIrradiance) {
  const worlds::World w = flatWorld();
  const auto off = preparedSweep(w, {{"ground_blend", "0"}});
  const auto on = preparedSweep(w, {{"ground_blend", "2"}});
  const glm::vec3 up(0.f, 0.f, 1.f), side(0.f, 1.f, 0.f);
  const glm::dvec3 at(30.3, 31.7, 0.0);
  const glm::vec3 ground = off->ambient(at, up);
  ASSERT_GT(ground.g, 0.f);
  EXPECT_LT(off->ambient(at, side).g, 0.9f * ground.g) << "without the blend a sideways normal reads less than the ground's";
  // The ground map's height and normal come from ray hits in float: within 1e-5 m of flat.
  constexpr float kRel = 1e-4f;
  EXPECT_NEAR(on->ambient(at, up).g, ground.g, kRel * ground.g);
  EXPECT_NEAR(on->ambient(at, side).g, ground.g, kRel * ground.g);
  EXPECT_NEAR(on->ambient(at, side).r, ground.r, kRel * ground.r);
  for (double z : {2.5, 3.5, 10.0}) {
    const glm::dvec3 p(30.3, 31.7, z);
    EXPECT_EQ(on->ambient(p, side), off->ambient(p, side)) << "at " << z << " m";
  }
  const glm::dvec3 mid(30.3, 31.7, 1.0);  // halfway up the blend
  const glm::vec3 want = 0.5f * off->ambient(mid, side) + 0.5f * off->ambient(mid, up);
  EXPECT_NEAR(on->ambient(mid, side).g, want.g, kRel * want.g);
}

}  // namespace
}  // namespace drtv::eval
