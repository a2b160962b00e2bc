// The material grids' compact form (material_codec.h) and the streamed hierarchy
// (grid_streamer.h): lossless, every bad prefix rejected; a streamed fine grid is the sweep of its
// material under its lighting step's coarse grid, word for word, whatever the threads; grids land
// no sooner than the simulated job time and go when their sector is no longer wanted.
#include <cstring>
#include <thread>

#include <gtest/gtest.h>

#include "drtv/sweep/grid_streamer.h"
#include "drtv/sweep/material_codec.h"
#include "drtv/sweep/sweep.h"

namespace drtv::sweep {
namespace {

// A grid with air, ground (density 1), a partly dense object and odd values: a box of density 0.7
// and a canopy of 0.3 over a ground at 2 cells, reflectances varying per cell.
MaterialGrid testMaterial(const GridShape& s) {
  MaterialGrid m = MaterialGrid::clear(s);
  m.ground_z.assign(size_t(s.size.x) * size_t(s.size.y), 0.f);
  for (int k = 0; k < s.size.z; ++k)
    for (int j = 0; j < s.size.y; ++j)
      for (int i = 0; i < s.size.x; ++i) {
        const size_t c = s.index(i, j, k);
        if (k < 2) m.density[c] = 1.f, m.reflectance[c] = {0.2f + 0.001f * float(i), 0.3f, 0.1f + 0.002f * float(j)};
        else if (i >= s.size.x / 4 && i < s.size.x / 2 && j >= s.size.y / 4 && j < s.size.y / 2 && k < 5)
          m.density[c] = 0.7f, m.reflectance[c] = {0.5f, 0.4f, 0.35f};
        else if (k == s.size.z - 2 && i > s.size.x / 2) m.density[c] = 0.3f, m.reflectance[c] = {0.05f, 0.25f, 0.04f};
      }
  for (int j = 0; j < s.size.y; ++j)
    for (int i = 0; i < s.size.x; ++i) m.ground_z[size_t(i) + size_t(s.size.x) * size_t(j)] = float(s.origin.z + 2 * s.cell_m) - 1e-3f * float(i);
  return m;
}

template <class T, class A>
bool sameBits(const std::vector<T, A>& a, const std::vector<T, A>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}
bool sameWords(const LightGrid& a, const LightGrid& b) {
  return a.shape.size == b.shape.size && a.shape.origin == b.shape.origin && sameBits(a.light, b.light) &&
         sameBits(a.average, b.average) && sameBits(a.dominant, b.dominant);
}

Sky testSky() { return Sky::tropicalDefault(); }

TEST(MaterialCodec, RoundTripsBitForBit) {
  const MaterialGrid m = testMaterial({{128.0, -64.0, -3.0}, 1.0, {64, 64, 12}});
  const std::vector<uint8_t> bytes = encodeMaterial(m);
  auto back = decodeMaterial(bytes);
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->shape.origin, m.shape.origin);
  EXPECT_EQ(back->shape.size, m.shape.size);
  EXPECT_EQ(back->shape.cell_m, m.shape.cell_m);
  EXPECT_TRUE(sameBits(back->density, m.density));
  EXPECT_TRUE(sameBits(back->reflectance, m.reflectance));
  EXPECT_TRUE(sameBits(back->ground_z, m.ground_z));
  // What "compact" buys on this mostly empty grid: at least 10x under its 786 KB of planes.
  EXPECT_LT(bytes.size() * 10, m.shape.cellCount() * 16);
}

TEST(MaterialCodec, RejectsEveryTruncatedPrefixTrailingBytesAndABadVersion) {
  const std::vector<uint8_t> bytes = encodeMaterial(testMaterial({{0.0, 0.0, 0.0}, 1.0, {16, 16, 8}}));
  for (size_t n = 0; n < bytes.size(); ++n)
    EXPECT_FALSE(decodeMaterial(std::span(bytes.data(), n)).has_value()) << "prefix of " << n << " bytes";
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  auto trailing = decodeMaterial(longer);
  ASSERT_FALSE(trailing.has_value());
  EXPECT_NE(trailing.error().message.find("trailing"), std::string::npos) << trailing.error().message;
  std::vector<uint8_t> v2 = bytes;
  v2[4] = 2;
  auto version = decodeMaterial(v2);
  ASSERT_FALSE(version.has_value());
  EXPECT_NE(version.error().message.find("byte 4: version 2"), std::string::npos) << version.error().message;
}

struct Scene {
  MaterialGrid coarse = testMaterial({{0.0, 0.0, -32.0}, 16.0, {8, 8, 6}});  // 2 x 2 sectors
  MaterialGrid fine = testMaterial({{64.0, 0.0, -2.0}, 1.0, {64, 64, 10}});   // sector (1, 0)
  GridStreamer::MaterialBytes bytes = std::make_shared<const std::vector<uint8_t>>(encodeMaterial(fine));
};

// The grids the technique's prepare-time sweep makes for `hour`: the coarse one with the sun's
// direct part kept, the fine one with its edges from it.
std::pair<SweptGrid, SweptGrid> direct(const Scene& s, const GridStreamerOptions& o, double hour) {
  const Sky sky = testSky();
  const SkyInput in{skyLight(sky, hour), sunLight(sky, hour, o.sun_disc_rad)};
  SweepOptions so = o.sweep;
  so.keep_direct = true;
  SweptGrid coarse = sweep(s.coarse, in, nullptr, so);
  so.keep_direct = false;
  SweptGrid fine = sweep(s.fine, in, &coarse, so);
  return {std::move(coarse), std::move(fine)};
}

// Runs `g` at camera time steps of 1/60 s from `t` until idle (or 10 s of camera time); real time
// passes too, for worker threads.
double runUntilIdle(GridStreamer& g, double t, double hour) {
  for (int i = 0; i < 600; ++i, t += 1.0 / 60.0) {
    if (g.update(t, hour).idle) return t;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ADD_FAILURE() << "never idle";
  return t;
}

TEST(GridStreamer, FineGridIsTheSweepOfItsMaterialUnderItsStepsCoarseGridWhateverTheThreads) {
  const Scene s;
  for (int workers : {0, 1, 2}) {
    GridStreamerOptions o;
    o.workers = workers;
    o.resweep_hours = 0.25;
    GridStreamer g(testSky(), s.coarse, o, 9.1);  // step 36: 9.0 h
    EXPECT_EQ(g.stepHour(9.1), 9.0);
    g.setWanted({{SectorKey{1, 0}, s.bytes}});
    double t = runUntilIdle(g, 0.0, 9.1);
    auto [coarse9, fine9] = direct(s, o, 9.0);
    ASSERT_NE(g.fine({1, 0}), nullptr) << workers << " workers";
    EXPECT_TRUE(sameWords(g.coarse().light, coarse9.light)) << workers << " workers";
    EXPECT_TRUE(sameWords(g.fine({1, 0})->light, fine9.light)) << workers << " workers";
    // The hour moves on: both are re-swept for the new step (15.5 h), again word for word.
    runUntilIdle(g, t, 15.4);
    auto [coarse15, fine15] = direct(s, o, 15.5);
    EXPECT_EQ(g.fineHour({1, 0}), 15.5);
    EXPECT_TRUE(sameWords(g.coarse().light, coarse15.light)) << workers << " workers";
    EXPECT_TRUE(sameWords(g.fine({1, 0})->light, fine15.light)) << workers << " workers";
    EXPECT_FALSE(sameWords(fine9.light, fine15.light));  // the comparison can tell hours apart
    // The 9:00 grid, retired when 15:30's landed, is kept as a spare; the next step's fine grid is
    // swept into it (sweepInto), and is still the sweep of its material word for word.
    EXPECT_EQ(g.update(t, 15.4).spares, 1) << workers << " workers";
    runUntilIdle(g, t, 20.1);
    auto [coarse20, fine20] = direct(s, o, 20.0);
    EXPECT_EQ(g.fineHour({1, 0}), 20.0);
    EXPECT_TRUE(sameWords(g.fine({1, 0})->light, fine20.light)) << workers << " workers: swept into a spare";
  }
}

TEST(GridStreamer, DeterministicGridsLandAfterTheSimulatedJobTimeAndGoWhenNoLongerWanted) {
  const Scene s;
  GridStreamerOptions o;
  o.workers = 0;
  o.simulated_job_s = 0.1;
  GridStreamer g(testSky(), s.coarse, o, 12.0);
  g.setWanted({{SectorKey{1, 0}, s.bytes}});
  GridStreamerStats st = g.update(0.0, 12.0);
  EXPECT_GT(st.inline_ms, 0.0);  // the sweep ran, inline
  EXPECT_EQ(g.fine({1, 0}), nullptr);
  EXPECT_EQ(g.update(0.099, 12.0).fine_grids, 0);
  st = g.update(0.1, 12.0);
  EXPECT_EQ(st.landed, 1);
  ASSERT_NE(g.fine({1, 0}), nullptr);
  EXPECT_TRUE(st.idle);
  g.setWanted({});
  st = g.update(0.2, 12.0);
  EXPECT_EQ(g.fine({1, 0}), nullptr);
  EXPECT_EQ(st.fine_grids, 0);
  EXPECT_EQ(st.bytes, g.coarse().bytes());
}

TEST(GridStreamer, AFailedDecodeIsReportedNotInstalled) {
  const Scene s;
  GridStreamerOptions o;
  o.workers = 0;
  o.simulated_job_s = 0.0;
  GridStreamer g(testSky(), s.coarse, o, 12.0);
  auto bad = std::make_shared<const std::vector<uint8_t>>(s.bytes->begin(), s.bytes->end() - 1);
  g.setWanted({{SectorKey{1, 0}, bad}});
  g.update(0.0, 12.0);
  const GridStreamerStats st = g.update(0.0, 12.0);
  EXPECT_EQ(st.failed, 1);
  EXPECT_EQ(g.fine({1, 0}), nullptr);
  ASSERT_FALSE(g.errors().empty());
  EXPECT_NE(g.errors().front().find("sector (1,0)"), std::string::npos) << g.errors().front();
}

}  // namespace
}  // namespace drtv::sweep
