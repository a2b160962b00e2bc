// The engine-facing Runtime: relight only what changed, interiors, distant ambient, queries,
// input validation, and finite output for any finite input.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "drtv/runtime/runtime.h"
#include "runtime_world.h"

namespace drtv::runtime {
namespace {

// Ambient goes through 8-bit texels: one step of the HDR scale, times the sum of |weights| (<= 2).
float quantStep(const Runtime& rt) { return 2.f * rt.volume().read()->hdrScale() / 255.f; }

// 5 x 5 sectors around the origin, 10:00, camera near the origin. (Runtime does not move: it
// owns the published volumes that readers lock.)
void populate(Runtime& rt) {
  for (int y = -2; y <= 2; ++y)
    for (int x = -2; x <= 2; ++x) EXPECT_TRUE(rt.addSector(testing::makeSector({x, y}, {}, 1)));
  EXPECT_TRUE(rt.setTime(10.0));
  rt.update({10.0, 10.0, 12.0});
}

TEST(Runtime, RelightsOnlyWhenTheLightingMovesPastTheThreshold) {
  Runtime rt;
  populate(rt);
  EXPECT_EQ(rt.relightCount(), 1u);
  ASSERT_TRUE(rt.setTime(10.0 + 1.0 / 3600.0));
  rt.update({10.0, 10.0, 12.0});
  EXPECT_EQ(rt.relightCount(), 1u);
  ASSERT_TRUE(rt.setTime(11.0));
  rt.update({10.0, 10.0, 12.0});
  EXPECT_EQ(rt.relightCount(), 2u);
  // Lights alone relight only the sectors they reach (moving_lights_test.cpp): these have no LPRT.
  ASSERT_TRUE(rt.setLights({{"lamp", {0.0, 0.0, 12.0}, glm::vec3(1.f), 5.f}}));
  rt.update({10.0, 10.0, 12.0});
  EXPECT_EQ(rt.relightCount(), 2u);
  EXPECT_EQ(rt.lightRelightCount(), 0u);
  // A new sky description relights everything.
  ASSERT_TRUE(rt.setLighting(Sky::tropicalDefault(), {}, {}));
  rt.update({10.0, 10.0, 12.0});
  EXPECT_EQ(rt.relightCount(), 3u);
}

TEST(Runtime, ASectorStreamingInIsRelitAloneAndAppearsInTheVolume) {
  RuntimeOptions o;
  Runtime rt(o);
  for (int x = -2; x <= 2; ++x) ASSERT_TRUE(rt.addSector(testing::makeSector({x, 0}, {}, 1)));
  ASSERT_TRUE(rt.setTime(9.0));
  rt.update({0.0, 70.0, 12.0});
  const glm::dvec3 p(20.0, 80.0, 12.0);  // in sector (0,1), not yet resident: open sky fallback
  const ProbeCache& cache = rt.cache();
  EXPECT_FALSE(rt.nearestProbeColours(p).has_value());
  ASSERT_TRUE(rt.addSector(testing::makeSector({0, 1}, {}, 1)));
  rt.update({0.0, 70.0, 12.0});
  EXPECT_EQ(rt.relightCount(), 1u);  // no full relight
  const auto colours = rt.nearestProbeColours(p);
  ASSERT_TRUE(colours.has_value());
  // The volume texel there now holds that probe's colours (nearest mode, quantised).
  const auto view = rt.volume().read();
  const BasisColours fetched = fetchVolume(view.volume(), (glm::floor(p / 2.0) + 0.5) * 2.0);
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fetched[b][c], (*colours)[b][c], view->hdrScale() / 255.f);
  EXPECT_EQ(cache.sectorCount(), 6);
}

TEST(Runtime, AmbientInsideTheVolumeIsTheVolumeLookup) {
  Runtime rt;
  populate(rt);
  const glm::dvec3 p(12.0, 3.0, 12.0);
  const glm::vec3 n = glm::normalize(glm::vec3(0.3f, 0.2f, 1.f));
  const AmbientSample s = rt.ambient(p, n);
  EXPECT_EQ(s.volume_weight, 1.f);
  EXPECT_EQ(s.interior, -1);
  const auto view = rt.volume().read();
  EXPECT_EQ(s.irradiance, sampleVolume(view.volume(), p, n, rt.options().normal_offset_m));
  EXPECT_GT(s.irradiance.b, 0.f);
}

TEST(Runtime, AmbientNormalIsUnitOrUpForAnyInput) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const glm::vec3 up(0.f, 0.f, 1.f);
  EXPECT_EQ(ambientNormal({3.f, 0.f, 4.f}), glm::vec3(0.6f, 0.f, 0.8f));
  // Squared, these overflow (3e38^2) or underflow (1e-30^2) a float: the direction survives.
  const glm::vec3 big = ambientNormal({3e38f, 0.f, -3e38f}), tiny = ambientNormal({0.f, 1e-30f, 0.f});
  EXPECT_NEAR(big.x, 0.70710678f, 1e-6f);
  EXPECT_NEAR(big.z, -0.70710678f, 1e-6f);
  EXPECT_EQ(tiny, glm::vec3(0.f, 1.f, 0.f));
  for (const glm::vec3& n : {glm::vec3(0.f), glm::vec3(nan, 0.f, 0.f), glm::vec3(inf, 0.f, 0.f), glm::vec3(inf, -inf, 1.f)})
    EXPECT_EQ(ambientNormal(n), up);
  // ambient() reads the normal so: a zero normal shades as +Z.
  Runtime rt;
  populate(rt);
  EXPECT_EQ(rt.ambient({12.0, 3.0, 12.0}, glm::vec3(0.f)).irradiance, rt.ambient({12.0, 3.0, 12.0}, up).irradiance);
}

TEST(Runtime, FarFromTheCameraAmbientIsTheOccludedSky) {
  Runtime rt;
  populate(rt);
  const glm::dvec3 far(150.0, 150.0, 11.0);  // resident sector (2,2), outside the +-95 m volume
  const AmbientSample s = rt.ambient(far, {0, 0, 1});
  EXPECT_EQ(s.volume_weight, 0.f);
  EXPECT_EQ(s.irradiance, s.distant);
  const float occ = rt.occlusion().occlusion(far);
  EXPECT_GT(occ, 0.f);
  EXPECT_LT(occ, 1.f);
  const sh::Sh4 lobe = sh::cosineLobe({0, 0, 1});
  EXPECT_NEAR(s.distant.b, occ * glm::dot(lobe, rt.lighting().sky_sh[2]), 1e-6f);
  // High above the probes the sky is open.
  EXPECT_EQ(rt.occlusion().occlusion({150.0, 150.0, 500.0}), 1.f);
  // Outside every resident sector, too.
  EXPECT_EQ(rt.occlusion().occlusion({1e5, 0.0, 0.0}), 1.f);
}

// The slot-culled search against a brute-force scan of every resident probe: flagged probes of the
// interior first (nearest the designated position), else the nearest probe inside the box.
TEST(ProbeCache, InteriorProbeMatchesAScanOfEveryResidentProbe) {
  ProbeCache cache;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) {
      Sector s = testing::makeSector({x, y}, {}, 4);
      // Flag probes 3 and 40 of sector (x, y) as the designated probes of interiors (x + 2) and 1.
      for (int i : {3, 40}) {
        ProbeData d = unpackProbe(s.probes[i]);
        d.flags |= kProbeInterior;
        d.interior = uint16_t(i == 3 ? x + 2 : 1);
        s.probes[i] = packProbe(d);
      }
      ASSERT_TRUE(cache.addSector(s));
    }
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-90.0, 150.0), h(0.5, 40.0);
  for (int trial = 0; trial < 300; ++trial) {
    const uint16_t index = uint16_t(1 + trial % 5);  // 4 and 5 have no flagged probe
    const glm::dvec3 designated(u(rng), u(rng), 5.0 + 30.0 * std::fabs(u(rng)) / 150.0);
    const glm::dvec3 half(h(rng), h(rng), h(rng) * 0.3);
    const glm::dvec3 lo = designated - half, hi = designated + half;
    ProbeRef flagged, inside;
    double fd = INFINITY, id = INFINITY;
    for (int s = 0; s < cache.maxSectors(); ++s) {
      if (!cache.slotUsed(s)) continue;
      for (int i = 0; i < cache.slot(s).probe_count; ++i) {
        const ProbeRef p{s, i};
        const glm::dvec3 w = cache.worldPosition(p);
        const double d2 = glm::dot(w - designated, w - designated);
        if ((cache.flags(p) & kProbeInterior) && cache.interior(p) == index) {
          if (d2 < fd) fd = d2, flagged = p;
        } else if (glm::all(glm::greaterThanEqual(w, lo)) && glm::all(glm::lessThanEqual(w, hi)) && d2 < id) {
          id = d2, inside = p;
        }
      }
    }
    EXPECT_EQ(cache.interiorProbe(index, designated, lo, hi), flagged.valid() ? flagged : inside) << "trial " << trial;
  }
}

// The interiors a sector's arrival or departure can change are resolved again alone (a town's
// 18,756 rooms made every load scan them all): after any order of loads and unloads each
// interior's probe is the one a runtime resolving every interior from scratch finds.
TEST(Runtime, InteriorsResolvedPerSectorMatchAFullResolveAfterLoadsAndUnloads) {
  std::vector<InteriorVolume> interiors;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-150.0, 150.0), h(2.0, 40.0);
  for (int k = 0; k < 60; ++k) {
    InteriorVolume v;
    v.name = "room " + std::to_string(k);
    v.probe_position = glm::dvec3(u(rng), u(rng), 8.0);
    const glm::dvec3 half(h(rng), h(rng), 6.0);
    v.min = v.probe_position - half, v.max = v.probe_position + half;
    interiors.push_back(v);
  }
  auto sectorWithDesignated = [&](SectorKey key) {
    Sector s = testing::makeSector(key, {}, 4);
    // Probe 5 of each sector is the designated probe of the interior numbered by its key.
    ProbeData d = unpackProbe(s.probes[5]);
    d.flags |= kProbeInterior;
    d.interior = uint16_t(1 + ((key.ix + 3) * 7 + (key.iy + 3)) % 60);
    s.probes[5] = packProbe(d);
    return s;
  };
  Runtime rt;
  ASSERT_TRUE(rt.setLighting(Sky::tropicalDefault(), {}, interiors));
  std::vector<SectorKey> resident;
  std::uniform_int_distribution<int> key(-3, 2), coin(0, 2);
  for (int step = 0; step < 120; ++step) {
    const SectorKey k{key(rng), key(rng)};
    const bool there = std::find(resident.begin(), resident.end(), k) != resident.end();
    if (!there && coin(rng) > 0) {
      ASSERT_TRUE(rt.addSector(sectorWithDesignated(k)));
      resident.push_back(k);
    } else if (there) {
      EXPECT_TRUE(rt.removeSector(k));
      std::erase(resident, k);
    }
    Runtime fresh;
    ASSERT_TRUE(fresh.setLighting(Sky::tropicalDefault(), {}, interiors));
    for (const SectorKey& r : resident) ASSERT_TRUE(fresh.addSector(sectorWithDesignated(r)));
    for (size_t i = 0; i < interiors.size(); ++i) {
      const ProbeRef a = rt.interiorProbe(i), b = fresh.interiorProbe(i);
      ASSERT_EQ(a.valid(), b.valid()) << "step " << step << " interior " << i;
      if (a.valid()) {
        EXPECT_EQ(rt.cache().worldPosition(a), fresh.cache().worldPosition(b)) << "step " << step << " interior " << i;
      }
    }
  }
}

TEST(Runtime, RejectsNanAndNegativeLightingWithAClearError) {
  Runtime rt;
  Sky sky = Sky::tropicalDefault();
  sky.sky_zenith.keys[1].value.g = std::nanf("");
  auto r = rt.setLighting(sky, {}, {});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().message, "lighting: sky.sky_zenith[1].value: colour must be in [0, 1e+09]");
  auto l = rt.setLights({{"neg", {0.0, 0.0, 0.0}, {1.f, -1.f, 0.f}, 3.f}});
  ASSERT_FALSE(l);
  EXPECT_EQ(l.error().message, "lighting: lights[0].intensity: must be in [0, 1e+09]");
  auto t = rt.setTime(std::numeric_limits<double>::infinity());
  ASSERT_FALSE(t);
  EXPECT_NE(t.error().message.find("not a finite number"), std::string::npos);
}

TEST(Runtime, AmbientIsFiniteForExtremeFiniteInputs) {
  Runtime rt;
  populate(rt);
  const double big = std::numeric_limits<double>::max();
  for (const glm::dvec3& p : {glm::dvec3(0.0), glm::dvec3(big, -big, big), glm::dvec3(1e12, 1e12, -1e12), glm::dvec3(64.0, 64.0, 1e6)})
    for (const glm::vec3& n : {glm::vec3(0.f), glm::vec3(3e38f, -3e38f, 3e38f), glm::vec3(1e-30f, 0.f, 0.f), glm::vec3(0, 0, -1)}) {
      const AmbientSample s = rt.ambient(p, n);
      for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(s.irradiance[c]) && s.irradiance[c] >= 0.f);
    }
  rt.update({big, -big, big});  // the camera clamps
  EXPECT_TRUE(std::isfinite(rt.ambient({0.0, 0.0, 0.0}, {0, 0, 1}).irradiance.r));
}

TEST(Runtime, AmbientVariesSmoothlyAcrossTheVolumeEdge) {
  Runtime rt;
  populate(rt);
  // Walk outwards along +x through the fade band: no jump larger than the local texel steps.
  glm::vec3 last = rt.ambient({60.0, 10.0, 12.0}, {0, 0, 1}).irradiance;
  float worst = 0.f;
  for (double x = 60.0; x < 120.0; x += 0.25) {
    const glm::vec3 a = rt.ambient({x, 10.0, 12.0}, {0, 0, 1}).irradiance;
    worst = std::max(worst, glm::length(a - last));
    last = a;
  }
  EXPECT_LT(worst, 0.25f * glm::length(last) + 10 * quantStep(rt));
}

// A tool's runtime over a fixed set of sectors: every sector held, the cache grown past
// options.cache.max_sectors when they are more, and a sector the cache refuses named.
TEST(RuntimeForSectors, HoldsEverySectorGrowingTheCacheAndNamesTheOneItRefuses) {
  Manifest m;
  std::vector<Sector> sectors;
  for (int x = 0; x < 4; ++x) sectors.push_back(testing::makeSector({x, 7}, {}, 1));
  RuntimeOptions o;
  o.cache.max_sectors = 2;
  auto rt = runtimeForSectors(m, o, 10.0, sectors);
  ASSERT_TRUE(rt) << rt.error().message;
  EXPECT_EQ((*rt)->cache().maxSectors(), 4);
  for (const Sector& s : sectors) EXPECT_GE((*rt)->cache().slotOf(s.key), 0) << toString(s.key);
  sectors.push_back(sectors[2]);  // the same key again
  auto twice = runtimeForSectors(m, o, 10.0, sectors);
  ASSERT_FALSE(twice);
  EXPECT_EQ(twice.error().message.rfind("sector (2,7): ", 0), 0u) << twice.error().message;
  EXPECT_NE(twice.error().message.find("already resident"), std::string::npos) << twice.error().message;
}

}  // namespace
}  // namespace drtv::runtime
