// The report per building (buildings.h) on sectors made by hand: what joins probes into a
// building and what parts two, storeys found from heights with a staircase folded in, rooms
// counted once, the sectors' order irrelevant.
#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include "drtv/baker/buildings.h"
#include "drtv/formats/probe.h"

namespace drtv::baker {
namespace {

ProbeRecord probe(double x, double y, double z, uint16_t flags = kProbeCovered, uint16_t interior = 0) {
  ProbeRecord p{};
  p.position[0] = float(x), p.position[1] = float(y), p.position[2] = float(z);
  p.flags = flags;
  p.interior = interior;
  return p;
}

// Sector (0,0): a building of 3 storeys (floors 3 m apart) on a 2 m lattice over 10 x 6 m whose
// east half stands 0.7 m higher (a wing on rising ground) and whose last row of each floor is
// lifted 0.6 m (as over a sill); a staircase's 4 probes stacked beside it, a probe a step; the
// designated probes of rooms 1 and 2 stacked over one spot (room 2 twice: a double-height hall,
// one room, one count); open ground probes around it; and a tower of six storeys, one probe each.
// Sector (1,0): a one-storey hall 6.5 m tall that crosses into sector (2,0), 20 m east of the
// first building (a street apart), with a probe stacked 3 m over each of its floor's
// (kProbeStacked: one storey, two probes a column).
std::vector<Sector> town() {
  Sector a, b, c;
  a.key = {0, 0}, b.key = {1, 0}, c.key = {2, 0};
  for (int storey = 0; storey < 3; ++storey)
    for (int ix = 0; ix <= 5; ++ix)
      for (int iy = 0; iy <= 3; ++iy) a.probes.push_back(probe(20.0 + 2.0 * ix, 20.0 + 2.0 * iy, 1.5 + 3.0 * storey + (ix >= 3 ? 0.7 : 0.0) + (iy == 3 ? 0.6 : 0.0)));
  for (int k = 0; k < 4; ++k) a.probes.push_back(probe(31.0, 27.0, 2.2 + 0.6 * k));  // the stairs, 2.2-4.0 m
  a.probes.push_back(probe(23.0, 23.0, 1.5, kProbeCovered | kProbeInterior, 1));
  a.probes.push_back(probe(23.0, 23.0, 4.5, kProbeCovered | kProbeInterior, 2));
  a.probes.push_back(probe(23.0, 23.0, 7.5, kProbeCovered | kProbeInterior, 2));
  for (int k = 0; k < 10; ++k) a.probes.push_back(probe(4.0 * k, 2.0, 1.0, 0));  // open ground: not a building's
  for (int k = 0; k < 6; ++k) a.probes.push_back(probe(50.0, 50.0, 1.5 + 3.0 * k));  // a tower, a probe a storey
  for (int ix = 0; ix < 10; ++ix) {
    const double x = 50.0 + 2.0 * ix;  // world x 114-132: sector 1 then sector 2
    (x < 64.0 ? b : c).probes.push_back(probe(x < 64.0 ? x : x - 64.0, 24.0, 2.0));
    (x < 64.0 ? b : c).probes.push_back(probe(x < 64.0 ? x : x - 64.0, 24.0, 5.01, kProbeCovered | kProbeStacked));
  }
  return {a, b, c};
}

TEST(Buildings, CoveredProbesJoinIntoBuildingsWithTheirStoreysAndRooms) {
  BuildingCollector c;
  for (const Sector& s : town()) c.addSector(s);
  const std::vector<BuildingStats> bs = c.buildings();
  ASSERT_EQ(bs.size(), 3u);
  const BuildingStats& house = bs[0];
  EXPECT_EQ(house.probes, 3u * 24u + 4u + 3u);
  // Per storey: the lattice's 24, the stairs' and the rooms' column one each; the stairs' fourth
  // probe (under 5 % of the ground's) folded into the top storey. The heights of the wings, the
  // sills and the steps do not matter: a probe's storey is its rank in its column.
  EXPECT_EQ(house.storey_probes, (std::vector<size_t>{26, 26, 27}));
  EXPECT_EQ(house.rooms, 2u);
  EXPECT_EQ(house.sectors, 1);
  EXPECT_DOUBLE_EQ(house.min.x, 20.0);
  EXPECT_DOUBLE_EQ(house.max.y, 27.0);
  EXPECT_NEAR(house.bottom_z, 1.5, 1e-6);
  EXPECT_NEAR(house.top_z, 8.8, 1e-6);
  EXPECT_EQ(house.bytes, house.probes * (sizeof(ProbeRecord) + 512u));
  const BuildingStats& hall = bs[1];
  EXPECT_EQ(hall.probes, 20u);
  EXPECT_EQ(hall.storey_probes, std::vector<size_t>{20}) << "the stacked probes start no storey";
  EXPECT_EQ(hall.sectors, 2) << "joined across the sector border";
  EXPECT_EQ(hall.rooms, 0u);
  EXPECT_EQ(bs[2].storey_probes, std::vector<size_t>(6, 1)) << "the tower's storeys, none folded";
}

TEST(Buildings, TheSectorsOrderDoesNotMatterAndAWiderJoinMergesTheTwo) {
  std::vector<Sector> s = town();
  BuildingCollector a;
  for (const Sector& x : s) a.addSector(x);
  std::reverse(s.begin(), s.end());
  BuildingCollector b;
  for (const Sector& x : s) b.addSector(x);
  const auto ba = a.buildings(), bb = b.buildings();
  ASSERT_EQ(ba.size(), bb.size());
  for (size_t i = 0; i < ba.size(); ++i) {
    EXPECT_EQ(ba[i].probes, bb[i].probes);
    EXPECT_EQ(ba[i].storey_probes, bb[i].storey_probes);
    EXPECT_EQ(ba[i].min, bb[i].min);
  }
  // The hall starts at world x 114, the tower stands at 50, the house ends at 30.
  BuildingCollector wide({.join_m = 100.0});
  for (const Sector& x : s) wide.addSector(x);
  EXPECT_EQ(wide.buildings().size(), 1u);
  EXPECT_TRUE(BuildingCollector().buildings().empty());
}

}  // namespace
}  // namespace drtv::baker
