// Residency ranking: footprint first, look-ahead, hysteresis, archive holes.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include <limits>

#include "drtv/streamer/residency.h"

namespace drtv::streamer {
namespace {

Manifest gridManifest(int nx, int ny, std::vector<SectorKey> holes = {}) {
  Manifest m;
  for (int ix = 0; ix < nx; ++ix)
    for (int iy = 0; iy < ny; ++iy)
      if (std::find(holes.begin(), holes.end(), SectorKey{ix, iy}) == holes.end()) {
        SectorEntry e;
        e.key = {ix, iy};
        e.probes = 70;
        m.sectors.push_back(e);
      }
  m.bounds_max = {64.0 * nx, 64.0 * ny, 50};
  return m;
}

// The slow, obviously correct distance: sample the segment densely and take the nearest point
// of the square for each sample.
double bruteDistance(SectorKey key, glm::dvec2 a, glm::dvec2 b) {
  double best = 1e300;
  for (int i = 0; i <= 20000; ++i) {
    const glm::dvec2 p = a + (b - a) * (i / 20000.0);
    const double x0 = key.ix * 64.0, y0 = key.iy * 64.0;
    const double dx = std::max({x0 - p.x, 0.0, p.x - (x0 + 64)}), dy = std::max({y0 - p.y, 0.0, p.y - (y0 + 64)});
    best = std::min(best, std::sqrt(dx * dx + dy * dy));
  }
  return best;
}

// A 300 m segment sampled 20000 times: samples are 1.5 cm apart, so the brute force is within that.
constexpr double kBruteSamplingToleranceM = 0.02;

TEST(DistanceToSegment, MatchesADenselySampledReference) {
  const glm::dvec2 segs[][2] = {{{10, 10}, {300, 40}}, {{-50, 200}, {130, -80}}, {{32, 32}, {32, 32}}, {{200, 0}, {200, 300}}};
  for (auto& s : segs)
    for (int ix = -2; ix <= 5; ++ix)
      for (int iy = -2; iy <= 5; ++iy)
        EXPECT_NEAR(distanceToSegment({ix, iy}, s[0], s[1]), bruteDistance({ix, iy}, s[0], s[1]), kBruteSamplingToleranceM)
            << ix << "," << iy;
}

TEST(RankSectors, PutsEverySectorOfTheVolumeFootprintFirst) {
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  Camera cam{{500, 500, 30}, {100, 0, 0}};
  std::vector<RankedSector> ranked;
  rankSectors(m, cam, o, {}, ranked);
  std::vector<SectorKey> foot;
  footprintSectors(m, cam.position_m, o, foot);
  ASSERT_FALSE(foot.empty());
  for (SectorKey k : foot) {
    auto it = std::find_if(ranked.begin(), ranked.end(), [&](const RankedSector& r) { return r.key == k; });
    ASSERT_NE(it, ranked.end());
    EXPECT_EQ(it->tier, 0);
    EXPECT_LT(it - ranked.begin(), o.max_sectors);
  }
  // Tiers never interleave.
  EXPECT_TRUE(std::is_sorted(ranked.begin(), ranked.end(), [](auto& a, auto& b) { return a.tier < b.tier; }));
}

TEST(RankSectors, FootprintOfA192MetreVolumeCoversAtMostFourByFourSectors) {
  const Manifest m = gridManifest(16, 16);
  std::vector<SectorKey> foot;
  footprintSectors(m, {500, 500, 0}, {}, foot);
  EXPECT_EQ(foot.size(), 16u);  // 404..596 spans sectors 6..9 on each axis
  footprintSectors(m, {544, 544, 0}, {}, foot);  // 448..640: edges on sector boundaries, 3 x 3
  EXPECT_EQ(foot.size(), 9u);
}

TEST(RankSectors, LooksAheadAlongTheVelocity) {
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  std::vector<RankedSector> ranked;
  rankSectors(m, {{500, 500, 30}, {100, 0, 0}}, o, {}, ranked);
  ranked.resize(size_t(o.max_sectors));
  int ahead = 0, behind = 0;
  for (auto& r : ranked) {
    ahead += r.key.ix >= 10;
    behind += r.key.ix <= 5;
  }
  EXPECT_GT(ahead, behind);
  // Sector (11, 7) lies on the 200 m look-ahead segment (x 500..700, y 500): it is wanted.
  EXPECT_NE(std::find_if(ranked.begin(), ranked.end(), [](auto& r) { return r.key == SectorKey{11, 7}; }), ranked.end());
}

// Does the footprint about `p` overlap sector `key`'s open square, the footprint grown by `grow_m`?
bool footprintOverlaps(SectorKey key, glm::dvec3 p, const ResidencyOptions& o, double grow_m) {
  Footprint f = volumeFootprint(p, o);
  f.min -= glm::dvec2(grow_m);
  f.max += glm::dvec2(grow_m);
  return overlaps(key, f);
}

// The sectors the footprint overlaps at any of `samples` instants in [0, guard_s].
std::vector<SectorKey> bruteSwept(const Manifest& m, const Camera& cam, const ResidencyOptions& o, double grow_m, int samples) {
  std::vector<SectorKey> out;
  for (const SectorEntry& e : m.sectors)
    for (int i = 0; i <= samples; ++i)
      if (footprintOverlaps(e.key, cam.position_m + cam.velocity_mps * (o.guard_s * i / samples), o, grow_m)) {
        out.push_back(e.key);
        break;
      }
  return out;
}

TEST(RankSectors, ADiagonalFlightsSweptCornersAreTierZero) {
  // The 16 km² island's default path at 300 m/s: the footprint now and the one guard_s ahead
  // missed the sectors that only the footprint in between touches (its corners sweep them).
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  const Camera cam{{500, 500, 30}, {134.2, 268.3, 0}};
  std::vector<RankedSector> ranked;
  rankSectors(m, cam, o, {}, ranked);
  int corners = 0;
  for (SectorKey k : bruteSwept(m, cam, o, 0.0, 2000)) {
    const bool ends = footprintOverlaps(k, cam.position_m, o, 0.0) ||
                      footprintOverlaps(k, cam.position_m + cam.velocity_mps * o.guard_s, o, 0.0);
    corners += !ends;
    auto it = std::find_if(ranked.begin(), ranked.end(), [&](auto& r) { return r.key == k; });
    ASSERT_NE(it, ranked.end());
    EXPECT_EQ(it->tier, 0) << k.ix << "," << k.iy;
    EXPECT_LT(it - ranked.begin(), o.max_sectors);
  }
  EXPECT_GT(corners, 0);  // the case the two ends alone got wrong is in this camera
}

TEST(RankSectors, TierZeroIsWhatTheMovingFootprintOverlapsInOrderOfNeed) {
  const Manifest m = gridManifest(24, 24);
  uint32_t seed = 12345;
  auto uniform = [&](double lo, double hi) {
    seed = seed * 1664525u + 1013904223u;
    return lo + (hi - lo) * (seed >> 8) / double(1u << 24);
  };
  for (int trial = 0; trial < 25; ++trial) {
    ResidencyOptions o;
    o.guard_s = uniform(0.0, 2.0);
    const Camera cam{{uniform(300, 1200), uniform(300, 1200), 20}, {uniform(-600, 600), uniform(-600, 600), 0}};
    std::vector<RankedSector> ranked;
    rankSectors(m, cam, o, {}, ranked);
    std::vector<SectorKey> tier0;
    for (const RankedSector& r : ranked)
      if (r.tier == 0) tier0.push_back(r.key);
    std::sort(tier0.begin(), tier0.end());
    // Every sector a sampled instant overlaps is tier 0; every tier-0 sector is overlapped by the
    // footprint grown by the distance between samples (at most 850 m/s x 2 s / 1,000 = 1.7 m).
    for (SectorKey k : bruteSwept(m, cam, o, 0.0, 1000)) EXPECT_TRUE(std::binary_search(tier0.begin(), tier0.end(), k)) << trial;
    const auto loose = bruteSwept(m, cam, o, 1.8, 1000);
    for (SectorKey k : tier0) EXPECT_TRUE(std::find(loose.begin(), loose.end(), k) != loose.end()) << trial;
    // Tier 0 in order of need: a sector the footprint overlaps now first, never after a later one.
    for (size_t i = 1; i < ranked.size() && ranked[i].tier == 0; ++i) EXPECT_LE(ranked[i - 1].need_s, ranked[i].need_s) << trial;
    for (const RankedSector& r : ranked) {
      if (r.tier != 0) continue;
      EXPECT_EQ(r.need_s == 0.0, footprintOverlaps(r.key, cam.position_m, o, 0.0)) << trial;
    }
  }
}

TEST(RankSectors, APathAheadAsksForTheSectorsPastATurnBeforeTheCameraTurns) {
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  o.guard_s = 1.0;
  // North at 300 m/s from (500, 300); at (500, 500) the path turns east.
  Camera cam{{500, 300, 30}, {0, 300, 0}};
  std::vector<glm::dvec3> ahead;
  for (int i = 1; i <= 30; ++i) {
    const double s = 30.0 * i;  // 0.1 s apart
    ahead.push_back(s <= 200 ? glm::dvec3(500, 300 + s, 30) : glm::dvec3(500 + (s - 200), 500, 30));
  }
  auto tierOf = [&](const std::vector<RankedSector>& ranked, SectorKey k) {
    auto it = std::find_if(ranked.begin(), ranked.end(), [&](auto& r) { return r.key == k; });
    return it == ranked.end() ? -1 : it->tier;
  };
  std::vector<RankedSector> straight, turning;
  rankSectors(m, cam, o, {}, straight);
  cam.path_ahead = ahead;
  cam.path_step_s = 0.1;
  rankSectors(m, cam, o, {}, turning);
  // (10, 7) spans x 640..704, y 448..512: the footprint reaches it 0.81 s from now after the
  // turn, and never along the straight line north.
  EXPECT_EQ(tierOf(turning, {10, 7}), 0);
  EXPECT_EQ(tierOf(straight, {10, 7}), 1);
  // And (7, 10), straight on north (y 640..704, reached 0.81 s from now on the old heading), is
  // no longer tier 0: after the turn the footprint stops at y 596.
  EXPECT_EQ(tierOf(straight, {7, 10}), 0);
  EXPECT_EQ(tierOf(turning, {7, 10}), 1);
}

TEST(RankSectors, APathAlongTheVelocityRanksAsTheVelocityAlone) {
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  const Camera still{{420, 610, 30}, {-170, 240, 0}};
  Camera along = still;
  std::vector<glm::dvec3> ahead;
  for (int i = 1; i <= 8; ++i) ahead.push_back(still.position_m + still.velocity_mps * (0.25 * i));
  along.path_ahead = ahead;
  along.path_step_s = 0.25;
  std::vector<RankedSector> a, b;
  rankSectors(m, still, o, {}, a);
  rankSectors(m, along, o, {}, b);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].key, b[i].key) << i;
    EXPECT_EQ(a[i].tier, b[i].tier) << i;
    if (std::isinf(a[i].need_s)) EXPECT_EQ(a[i].need_s, b[i].need_s) << i;
    else EXPECT_NEAR(a[i].need_s, b[i].need_s, 1e-9) << i;
    EXPECT_NEAR(a[i].distance_m, b[i].distance_m, 1e-9) << i;
  }
}

TEST(RankSectors, AnAbsurdPathRanksWithoutFailing) {
  const Manifest m = gridManifest(8, 8);
  const std::vector<glm::dvec3> ahead(1000, glm::dvec3(300, 300, 0));
  const std::vector<glm::dvec3> wild = {{NAN, 0, 0}, {1e300, -1e300, 0}, {INFINITY, 5, 0}};
  for (const double step : {1e-300, 1e-9, 1e300, -1.0, double(NAN), double(INFINITY)})
    for (const auto* points : {&ahead, &wild}) {
      Camera cam{{256, 256, 10}, {50, 0, 0}};
      cam.path_ahead = *points;
      cam.path_step_s = step;
      cam.path_tolerance_m = step;
      std::vector<RankedSector> ranked;
      rankSectors(m, cam, {}, {}, ranked);
      // The footprint about the camera is always wanted first.
      std::vector<SectorKey> foot;
      footprintSectors(m, cam.position_m, {}, foot);
      for (SectorKey k : foot) {
        auto it = std::find_if(ranked.begin(), ranked.end(), [&](auto& r) { return r.key == k; });
        ASSERT_NE(it, ranked.end()) << step;
        EXPECT_EQ(it->tier, 0) << step;
      }
    }
}

TEST(RankSectors, StandingStillRanksADiscAroundTheCamera) {
  const Manifest m = gridManifest(16, 16);
  std::vector<RankedSector> ranked;
  rankSectors(m, {{512, 512, 0}, {0, 0, 0}}, {}, {}, ranked);
  for (size_t i = 1; i < ranked.size(); ++i) {
    if (ranked[i].tier == ranked[i - 1].tier) {
      EXPECT_LE(ranked[i - 1].distance_m, ranked[i].distance_m);
    }
  }
}

TEST(RankSectors, GivesHeldSectorsTheHysteresisBonus) {
  const Manifest m = gridManifest(16, 16);
  ResidencyOptions o;
  const Camera cam{{512, 512, 0}, {0, 0, 0}};
  std::vector<RankedSector> ranked;
  rankSectors(m, cam, o, {}, ranked);
  const RankedSector last = ranked[size_t(o.max_sectors)];  // the first one left out
  ASSERT_EQ(last.tier, 1);
  const std::vector<SectorKey> held{last.key};
  rankSectors(m, cam, o, held, ranked);
  auto it = std::find_if(ranked.begin(), ranked.end(), [&](auto& r) { return r.key == last.key; });
  EXPECT_LT(it - ranked.begin(), o.max_sectors);
  EXPECT_DOUBLE_EQ(it->score_m, it->distance_m - o.hysteresis_m);
}

TEST(RankSectors, RanksOnlySectorsTheArchiveHolds) {
  const Manifest m = gridManifest(4, 4, {{1, 1}, {2, 2}});
  std::vector<RankedSector> ranked;
  rankSectors(m, {{128, 128, 0}, {0, 0, 0}}, {}, {}, ranked);
  EXPECT_EQ(ranked.size(), 14u);
  for (auto& r : ranked) EXPECT_EQ(r.entry, m.find(r.key));
  rankSectors(m, {{-5000, -5000, 0}, {0, 0, 0}}, {}, {}, ranked);
  EXPECT_TRUE(ranked.empty());
}

// A camera far beyond int32 sector keys wants nothing: its keys are clamped (formats' sectorAt),
// not converted out of range. A NaN camera reads as the origin's sector there, and ranks at most
// the archive.
TEST(RankSectors, AnAbsurdCameraWantsNothing) {
  const Manifest m = gridManifest(4, 4);
  std::vector<RankedSector> ranked;
  std::vector<SectorKey> footprint;
  for (const double v : {1e300, -1e300}) {
    rankSectors(m, {{v, v, 0}, {0, 0, 0}}, {}, {}, ranked);
    EXPECT_TRUE(ranked.empty()) << v;
    footprintSectors(m, {v, v, 0}, {}, footprint);
    EXPECT_TRUE(footprint.empty()) << v;
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  rankSectors(m, {{nan, nan, 0}, {0, 0, 0}}, {}, {}, ranked);
  EXPECT_LE(ranked.size(), m.sectors.size());
}

TEST(RankSectors, IsIdenticalForIdenticalInputs) {
  const Manifest m = gridManifest(16, 16);
  std::vector<RankedSector> a, b;
  rankSectors(m, {{333.3, 777.7, 0}, {-70, 70, 0}}, {}, {}, a);
  rankSectors(m, {{333.3, 777.7, 0}, {-70, 70, 0}}, {}, {}, b);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].key, b[i].key);
}

// The block the tools hold about a camera: the 7 x 7 sectors centred on the camera's, within
// the 51 resident sectors, and clamped (never wrapped) at the ends of the key range.
TEST(ResidentBlock, IsTheSevenBySevenSectorsCentredOnTheCamerasWithinTheResidentCount) {
  const SectorRange b = residentBlock({100.0, -10.0, 5.0});  // sector (1,-1)
  EXPECT_EQ(b.x0, -2);
  EXPECT_EQ(b.x1, 4);
  EXPECT_EQ(b.y0, -4);
  EXPECT_EQ(b.y1, 2);
  EXPECT_EQ(b.count(), 49u);
  EXPECT_LE(b.count(), size_t(runtime::kMaxResidentSectors));
  EXPECT_TRUE(b.contains({1, -1}));
  EXPECT_TRUE(b.contains({4, 2}));
  EXPECT_FALSE(b.contains({5, 0}));
  EXPECT_FALSE(b.contains({0, -5}));
  const SectorRange far = residentBlock({1e300, -1e300, 0.0});
  EXPECT_EQ(far.x1, std::numeric_limits<int32_t>::max());
  EXPECT_EQ(far.x0, std::numeric_limits<int32_t>::max() - 3);
  EXPECT_EQ(far.y0, std::numeric_limits<int32_t>::min());
  EXPECT_EQ(far.y1, std::numeric_limits<int32_t>::min() + 3);
}

}  // namespace
}  // namespace drtv::streamer
