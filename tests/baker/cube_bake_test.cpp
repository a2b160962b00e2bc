// The ambient cube's transfer (transfer.h "The ambient cube", cube_bake.h): asking bakeTransfer
// for it leaves everything else it returns as it was (fc3 and sh-l1 bytes must not move), and
// bakeCube does not depend on the thread count.
#include <gtest/gtest.h>

#include <cstring>
#include <optional>

#include "drtv/baker/bake.h"
#include "drtv/baker/cube_bake.h"
#include "drtv/baker/transfer.h"
#include "test_worlds.h"

namespace drtv::baker {
namespace {

// Bit-for-bit equality of two arrays of floats (vectors of glm values or of floats).
template <typename T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

bool sameProbe(const ProbeData& a, const ProbeData& b) {
  return std::memcmp(&a.prt, &b.prt, sizeof(a.prt)) == 0 && a.sky_vis == b.sky_vis && a.sky_vis_sh == b.sky_vis_sh &&
         a.sky_fit_h == b.sky_fit_h && a.sky_fit_delta == b.sky_fit_delta && a.sky_moments == b.sky_moments &&
         a.backface_frac == b.backface_frac && a.height_m == b.height_m && a.mean_hit_m == b.mean_hit_m && a.flags == b.flags;
}

// The small world with a lamp inside the house, so that LPRT is baked too.
worlds::World litWorld() {
  worlds::World w = test::smallWorld();
  PointLight lamp;
  lamp.name = "lamp";
  lamp.position = {20.0, 20.0, 2.0};
  lamp.intensity = glm::vec3(20.f);
  lamp.radius_m = 12.f;
  w.lights.push_back(lamp);
  w.effects |= kEffectLocalLights;
  return w;
}

TEST(CubeTransfer, AskingForItLeavesFc3AndShL1AsTheyWere) {
  const worlds::World w = litWorld();
  auto g = raytrace::WorldGeometry::build(w, "test");
  ASSERT_TRUE(g) << g.error().message;
  const raytrace::SectorGeometry geometry = g->gather({0, 0}, 80.0);
  auto scene = raytrace::RayScene::build(geometry.vertices);
  ASSERT_TRUE(scene);
  const std::vector<glm::vec3> probes = {{20.f, 20.f, 1.5f}, {10.f, 30.f, 1.5f}, {40.f, 5.f, 3.f}, {-20.f, -20.f, 2.f}};
  const std::vector<glm::vec3> sources = {{20.f, 20.f, 1.5f}, {5.f, 5.f, 1.5f}};
  const std::vector<glm::vec3> sun = sunSamples(Sky::tropicalDefault(), 6);
  ASSERT_EQ(sun.size(), 6u);
  for (Representation r : {Representation::kFc3, Representation::kShL1}) {
    TransferSettings s;
    s.probe_rays_per_basis = 64;
    s.surfel_rays = 16;
    s.representation = r;
    TransferStats stats_a, stats_b;
    std::vector<float> lprt_a, lprt_b, sun_a, sun_b;
    CubeTransfer cube;
    const auto a = bakeTransfer(*scene, geometry, probes, s, stats_a, sources, &lprt_a, sun, &sun_a);
    const auto b = bakeTransfer(*scene, geometry, probes, s, stats_b, sources, &lprt_b, sun, &sun_b, &cube);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(sameProbe(a[i], b[i])) << representationName(r) << " probe " << i;
    EXPECT_TRUE(sameBits(lprt_a, lprt_b)) << representationName(r);
    EXPECT_TRUE(sameBits(sun_a, sun_b)) << representationName(r);
    EXPECT_EQ(sun_a.empty(), r == Representation::kFc3);  // only sh-l1 has a sun block
    // The cube got its blocks, whatever the representation.
    EXPECT_EQ(cube.prt.size(), probes.size());
    EXPECT_EQ(cube.sun.size(), probes.size() * sun.size() * 3 * kCubeAxes);
    EXPECT_EQ(cube.lprt.size(), probes.size() * sources.size() * 3 * kCubeAxes);
  }
}

TEST(CubeTransfer, BakeCubeDoesNotDependOnTheThreadCount) {
  const worlds::World w = litWorld();
  BakeSettings settings = BakeSettings::forQuality(Quality::kDraft, 7);
  auto baked = bakeInMemory(w, "small", settings, std::nullopt, 2);
  ASSERT_TRUE(baked) << baked.error().message;
  ASSERT_FALSE(baked->sectors.empty());
  // The interiors the bake found (its house is a closed room): the placements bakeCube repeats are
  // then the bake's.
  auto one = bakeCube(w, "small", settings, baked->sectors, 1, &baked->manifest.interiors);
  auto two = bakeCube(w, "small", settings, baked->sectors, 2, &baked->manifest.interiors);
  ASSERT_TRUE(one && two);
  ASSERT_EQ(one->sectors.size(), two->sectors.size());
  EXPECT_EQ(one->rays, two->rays);
  size_t lprt = 0;
  for (size_t i = 0; i < one->sectors.size(); ++i) {
    const CubeTransfer &a = one->sectors[i].transfer, &b = two->sectors[i].transfer;
    EXPECT_EQ(a.prt.size(), baked->sectors[i].probes.size());
    EXPECT_TRUE(sameBits(a.prt, b.prt) && sameBits(a.sky_h, b.sky_h) && sameBits(a.sky_delta, b.sky_delta) &&
                sameBits(a.sun, b.sun) && sameBits(a.lprt, b.lprt))
        << "sector " << i;
    lprt += a.lprt.size();
  }
  EXPECT_GT(lprt, 0u);  // the lamp's LPRT was baked and compared
}

}  // namespace
}  // namespace drtv::baker
