// Relighting against the probe-by-probe reference of DESIGN.md, and the light kernel.
#include <cmath>

#include <gtest/gtest.h>

#include <algorithm>

#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/probe_cache.h"
#include "runtime_world.h"

namespace drtv::runtime {
namespace {

// Float SoA sums of ~10 terms against a double reference: a few float ulps of the largest term.
constexpr float kRelightRelTol = 2e-5f;
// LPRT adds up to 128 x 12 products of 16-bit values in float.
constexpr float kLprtRelTol = 1e-4f;

RelightInput lightingAt(double hour, std::span<const PointLight> lights = {}) {
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), hour);
  return {s.sky_sh, s.sun_sh, s.sky_direct_sh, lights, kAllComponents};
}

std::map<std::pair<SectorKey, int>, glm::dvec3> sharesByKey(const ProbeCache& cache, const std::vector<LightShare>& shares) {
  std::map<std::pair<SectorKey, int>, glm::dvec3> m;
  for (const LightShare& s : shares) m[{cache.slot(s.probe.slot).key, s.probe.index}] += glm::dvec3(s.colour);
  return m;
}

void expectColoursNear(const BasisColours& got, const BasisColours& want, float rel_tol, const std::string& what) {
  float scale = 1e-6f;
  for (const glm::vec3& c : want) scale = std::max({scale, c.r, c.g, c.b});
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[b][c], want[b][c], rel_tol * scale) << what << " basis " << b << " channel " << c;
}

TEST(Relight, MatchesTheReferenceFormulaForEveryProbeAndComponent) {
  ProbeCache cache;
  std::vector<Sector> sectors;
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      sectors.push_back(testing::makeSector({x - 1, y}, {.probes = 40 + 10 * x}, 1));
      ASSERT_TRUE(cache.addSector(sectors.back()));
    }
  for (uint32_t components : {kAllComponents, uint32_t(kComponentSunBounce), uint32_t(kComponentSkyBounce), uint32_t(kComponentDirectSky)}) {
    for (double hour : {7.0, 12.0, 18.2, 1.0}) {
      RelightInput in = lightingAt(hour);
      in.components = components;
      cache.relightAll(in);
      for (const Sector& s : sectors)
        for (int i = 0; i < int(s.probes.size()); ++i)
          expectColoursNear(cache.colours({cache.slotOf(s.key), i}), testing::referenceRelight(s, i, in.sky_sh, in.sun_sh, in.sky_direct_sh, {}, components),
                            kRelightRelTol, "probe " + std::to_string(i));
    }
  }
}

TEST(Relight, LocalLightsMatchTheReferenceOnBasesAndInSh) {
  for (bool on_bases : {true, false}) {
    ProbeCache cache;
    std::vector<Sector> sectors;
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        sectors.push_back(testing::makeSector({x, y}, {.probes = 30, .sources = 24, .lprt_on_bases = on_bases}, 2));
        ASSERT_TRUE(cache.addSector(sectors.back()));
      }
    const std::vector<PointLight> lights = {
        {"a", {10.0, 20.0, 12.0}, {3.f, 2.f, 1.f}, 15.f},
        {"b", {-30.0, -5.0, 10.0}, {0.f, 5.f, 0.f}, 40.f},
        {"far", {1e4, 0.0, 0.0}, {9.f, 9.f, 9.f}, 5.f}};
    RelightInput in = lightingAt(21.0, lights);
    cache.relightAll(in);
    const auto shares = sharesByKey(cache, cache.distributeLights(lights));
    EXPECT_FALSE(shares.empty());
    for (const Sector& s : sectors)
      for (int i = 0; i < int(s.probes.size()); ++i)
        expectColoursNear(cache.colours({cache.slotOf(s.key), i}), testing::referenceRelight(s, i, in.sky_sh, in.sun_sh, in.sky_direct_sh, shares),
                          kLprtRelTol, "probe " + std::to_string(i));
  }
}

// The shares of a light hung above its sources' surfaces are scaled down by the footprint factor
// (probe_cache.h, "Local lights"; its physics is tested against the path tracer in
// tests/reference/local_lights_test.cpp): they never add up to more than the light, and keep its colour.
TEST(LightKernel, SpreadsEachLightOnTheNearestSourceProbesWithinItsRadius) {
  ProbeCache cache({.max_sectors = 51, .sources_per_light = 4, .light_sources = LightSources::kNearest});
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) ASSERT_TRUE(cache.addSector(testing::makeSector({x, y}, {.probes = 30, .sources = 30}, 5)));
  const PointLight light{"l", {5.0, 5.0, 12.0}, {2.f, 4.f, 8.f}, 30.f};
  const std::vector<LightShare> shares = cache.distributeLights(std::span(&light, 1));
  ASSERT_EQ(shares.size(), 4u);
  glm::dvec3 sum(0.0);
  double farthest = 0.0;
  for (const LightShare& s : shares) {
    sum += glm::dvec3(s.colour);
    farthest = std::max(farthest, glm::distance(cache.worldPosition(s.probe), light.position));
  }
  EXPECT_GT(sum.x, 0.0);
  EXPECT_LE(sum.x, 2.0 * (1.0 + 1e-6));
  EXPECT_NEAR(sum.z / sum.x, 4.0, 1e-5);
  EXPECT_LT(farthest, light.radius_m);
}

// The default candidates: the probes the index grid names in the 4 cells around the light. The
// light's energy is kept whole, and every share sits on a probe one of those cells names.
TEST(LightKernel, KeepsEachLightsEnergyOnTheProbesTheGridNamesAroundIt) {
  ProbeCache cache({.max_sectors = 51, .sources_per_light = 4});
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) ASSERT_TRUE(cache.addSector(testing::makeSector({x, y}, {.probes = 30, .sources = 30}, 5)));
  const PointLight light{"l", {5.0, 5.0, 12.0}, {2.f, 4.f, 8.f}, 30.f};
  const std::vector<LightShare> shares = cache.distributeLights(std::span(&light, 1));
  ASSERT_FALSE(shares.empty());
  std::vector<ProbeRef> named;
  for (const double dx : {-2.0, 2.0})
    for (const double dy : {-2.0, 2.0}) named.push_back(cache.probeAt(light.position + glm::dvec3(dx, dy, 0.0)));
  glm::dvec3 sum(0.0);
  for (const LightShare& s : shares) {
    sum += glm::dvec3(s.colour);
    EXPECT_NE(std::find(named.begin(), named.end(), s.probe), named.end()) << "slot " << s.probe.slot << " probe " << s.probe.index;
  }
  EXPECT_NEAR(sum.x, 2.0, 1e-5);
  EXPECT_NEAR(sum.z, 8.0, 1e-5);
}

TEST(LightKernel, ALightExactlyOnAProbeIsFinite) {
  ProbeCache cache;
  ASSERT_TRUE(cache.addSector(testing::makeSector({0, 0}, {.probes = 20, .sources = 20}, 6)));
  // Source j names probe (7 j) mod 20 of sector (j%3-1, (j/3)%3-1): j = 4 is this sector's probe 8.
  const PointLight light{"on", cache.worldPosition({0, 8}), {1.f, 1.f, 1.f}, 0.5f};
  const auto shares = cache.distributeLights(std::span(&light, 1));
  ASSERT_EQ(shares.size(), 1u);
  EXPECT_EQ(shares[0].probe, (ProbeRef{0, 8}));
  EXPECT_EQ(shares[0].colour, glm::vec3(1.f));
  cache.relightAll(lightingAt(22.0, std::span(&light, 1)));
  for (int i = 0; i < 20; ++i)
    for (const glm::vec3& c : cache.colours({0, i})) EXPECT_TRUE(std::isfinite(c.r + c.g + c.b));
}

TEST(Relight, OneSectorAloneEqualsItsPartOfAFullRelight) {
  ProbeCache a, b;
  for (int x = 0; x < 3; ++x) {
    ASSERT_TRUE(a.addSector(testing::makeSector({x, 0}, {}, 9)));
    ASSERT_TRUE(b.addSector(testing::makeSector({x, 0}, {}, 9)));
  }
  const RelightInput in = lightingAt(15.0);
  a.relightAll(in);
  b.relightSector({1, 0}, in);
  for (int i = 0; i < 70; ++i) EXPECT_EQ(a.colours({a.slotOf({1, 0}), i}), b.colours({b.slotOf({1, 0}), i}));
  EXPECT_EQ(b.colours({b.slotOf({0, 0}), 0})[0], glm::vec3(0.f));  // not relit
}

// The packed RGBA8 texels, byte by byte, against the encoding as representation.h and
// probe_cache.h define it: fc3 bases and sh-l1's e0 as round(255 min(1, v / scale)) (negative:
// 0); sh-l1's e1..e3 as 128 + round(127 clamp(v / scale, -1, 1)), half away from zero. A scale
// below the brightest colour makes some bytes clamp.
TEST(ProbeCache, PackedTexelsAreTheEncodingOfTheRelitColours) {
  for (const Representation r : {Representation::kFc3, Representation::kShL1}) {
    ProbeCache cache({.representation = r});
    const bool sh_l1 = r == Representation::kShL1;
    ASSERT_TRUE(cache.addSector(testing::makeSector({0, 0}, {.sky_fit = sh_l1}, 4)));
    cache.relightAll(lightingAt(16.0));
    const float scale = cache.maxColour() * 0.6f;
    cache.pack(scale);
    const ProbeCache::SlotView v = cache.slot(0);
    int clamped = 0, mismatches = 0;
    for (int i = 0; i < v.probe_count; ++i)
      for (int c = 0; c < 3; ++c)
        for (int b = 0; b < 4; ++b) {
          const double x = double(v.colour[size_t(c * 4 + b) * size_t(v.colour_stride) + size_t(i)]) / double(scale);
          int want;
          if (sh_l1 && b > 0) {
            const double q = std::clamp(x, -1.0, 1.0) * 127.0;
            want = 128 + int(q >= 0.0 ? std::floor(q + 0.5) : std::ceil(q - 0.5));
            clamped += std::fabs(x) >= 1.0;
          } else {
            want = x <= 0.0 ? 0 : int(std::floor(255.0 * std::min(1.0, x) + 0.5));
            clamped += x >= 1.0;
          }
          const int got = int(v.packed[i * 3 + c] >> (8 * b) & 0xff);
          mismatches += got != want;
          EXPECT_EQ(got, want) << (sh_l1 ? "sh-l1" : "fc3") << " probe " << i << " channel " << c << " basis " << b << " x " << x;
          if (mismatches > 8) return;
        }
    EXPECT_GT(clamped, 0) << "the scale clamped nothing: the test exercises only half the encoding";
  }
}

TEST(Relight, HugeFiniteLightsGiveFiniteColours) {
  ProbeCache cache;
  ASSERT_TRUE(cache.addSector(testing::makeSector({0, 0}, {.probes = 20, .sources = 20}, 6)));
  const PointLight light{"sun-in-a-box", {30.0, 30.0, 12.0}, glm::vec3(3e38f), 100.f};
  RelightInput in = lightingAt(12.0, std::span(&light, 1));
  in.sky_sh[0] = sh::Sh4(3e38f);
  cache.relightAll(in);
  for (int i = 0; i < 20; ++i)
    for (const glm::vec3& c : cache.colours({0, i}))
      for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isfinite(c[k]) && c[k] >= 0.f && c[k] <= kMaxColour);
}

TEST(ProbeCache, RejectsDuplicatesFullSlotsAndBadGrids) {
  ProbeCache cache({.max_sectors = 2});
  ASSERT_TRUE(cache.addSector(testing::makeSector({0, 0}, {}, 1)));
  auto dup = cache.addSector(testing::makeSector({0, 0}, {}, 1));
  ASSERT_FALSE(dup);
  EXPECT_NE(dup.error().message.find("already resident"), std::string::npos);
  Sector bad = testing::makeSector({1, 0}, {.probes = 5}, 1);
  bad.grid.cells[100] = 9;
  auto r = cache.addSector(bad);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("names probe 9 of 5"), std::string::npos) << r.error().message;
  ASSERT_TRUE(cache.addSector(testing::makeSector({1, 0}, {}, 1)));
  auto full = cache.addSector(testing::makeSector({2, 0}, {}, 1));
  ASSERT_FALSE(full);
  EXPECT_NE(full.error().message.find("slots are used"), std::string::npos);
  EXPECT_TRUE(cache.removeSector({0, 0}));
  EXPECT_TRUE(cache.addSector(testing::makeSector({2, 0}, {}, 1)));
  EXPECT_EQ(cache.sectorCount(), 2);
}

TEST(ProbeCache, ProbeAtFollowsTheIndexGridAndResolvesEmptyCellsToTheNearestProbe) {
  ProbeCache cache;
  const Sector s = testing::makeSector({2, -3}, {.no_probe_fraction = 0.3f}, 4);
  ASSERT_TRUE(cache.addSector(s));
  for (int z = 0; z < kGridDim; z += 3)
    for (int y = 0; y < kGridDim; y += 2)
      for (int x = 0; x < kGridDim; x += 2) {
        const glm::dvec3 p(2 * 64.0 + x * 4 + 2, -3 * 64.0 + y * 4 + 2, z * 2 + 1);
        const ProbeRef r = cache.probeAt(p);
        ASSERT_TRUE(r.valid());
        const uint8_t cell = s.grid.at(x, y, z);
        if (cell != kNoProbe) {
          EXPECT_EQ(r.index, cell);
        } else {
          const glm::dvec3 d = cache.worldPosition(r) - p;
          for (int i = 0; i < 70; ++i) {
            const glm::dvec3 e = cache.worldPosition({r.slot, i}) - p;
            EXPECT_LE(glm::dot(d, d), glm::dot(e, e) + 1e-3);
          }
        }
      }
  EXPECT_FALSE(cache.probeAt({1e300, 0, 0}).valid());
  EXPECT_FALSE(cache.probeAt({0, 0, 0}).valid());  // sector (0,0) is not resident
}

}  // namespace
}  // namespace drtv::runtime
