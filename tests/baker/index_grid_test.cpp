// The index grid prefers the nearest VISIBLE probe (beyond the talk's nearest probe).
#include <gtest/gtest.h>

#include "drtv/baker/index_grid.h"
#include "drtv/raytrace/world_geometry.h"
#include "test_worlds.h"

namespace drtv::baker {
namespace {

struct HouseScene {
  raytrace::SectorGeometry geometry;
  std::optional<raytrace::RayScene> scene;
  // Room inside [15.4, 24.6] x [16.4, 23.6] x [0, 3]; the north wall is y in [23.6, 24].
  std::vector<glm::vec3> probes = {{20.f, 17.f, 1.5f}, {20.f, 26.f, 1.5f}};
  HouseScene() {
    worlds::World w = test::planeWorld(200.0, glm::vec3(0.5f));
    test::addHouse(w, {20.f, 20.f, 0.f});
    auto g = raytrace::WorldGeometry::build(w, "house");
    EXPECT_TRUE(g);
    geometry = g->gather({0, 0}, 64.0);
    auto s = raytrace::RayScene::build(geometry.vertices);
    EXPECT_TRUE(s);
    scene.emplace(std::move(*s));
  }
};

IndexGrid gridFor(const HouseScene& h, int candidates, IndexGridStats& stats, bool search_beyond = true) {
  IndexGrid grid;
  grid.z_min_m = 0.f;
  grid.cell_height_m = 1.f;
  fillIndexGrid(*h.scene, h.probes, IndexGridSettings{candidates, search_beyond}, grid, stats);
  return grid;
}

TEST(IndexGrid, ACellInsideAHouseTakesTheProbeInsideNotTheNearerOneOutside) {
  const HouseScene h;
  IndexGridStats stats;
  // Cell (4, 5, 1): centre (18, 22, 1.5), in the room, 4.5 m from the outside probe and 5.4 m
  // from the inside one.
  const IndexGrid visible = gridFor(h, 8, stats);
  EXPECT_EQ(visible.at(4, 5, 1), 0) << "the room's probe";
  EXPECT_GT(stats.cells_farther, 0u);
  IndexGridStats talk_stats;
  const IndexGrid nearest = gridFor(h, 1, talk_stats, /*search_beyond=*/false);
  EXPECT_EQ(nearest.at(4, 5, 1), 1) << "the talk's nearest probe is outside, behind the wall";
}

// With one candidate that is hidden, the cell still finds the probe it can see (issue 16: the
// nearest fallback named probes behind walls and inside buildings, and their light leaked in).
TEST(IndexGrid, ACellWhoseCandidatesAreAllHiddenSearchesTheOtherProbes) {
  const HouseScene h;
  IndexGridStats stats;
  const IndexGrid grid = gridFor(h, 1, stats);
  EXPECT_EQ(grid.at(4, 5, 1), 0) << "the room's probe, beyond the one hidden candidate";
  EXPECT_GT(stats.cells_searched, 0u);
  IndexGridStats talk;
  gridFor(h, 1, talk, false);
  EXPECT_EQ(talk.cells_searched, 0u);
  EXPECT_GE(talk.cells_unseen, stats.cells_searched) << "what the talk left to the nearest probe";
}

TEST(IndexGrid, EveryCellTakesAProbeAndOpenCellsTakeTheNearest) {
  const HouseScene h;
  IndexGridStats stats;
  const IndexGrid grid = gridFor(h, 8, stats);
  for (uint8_t c : grid.cells) EXPECT_LT(c, 2);
  // Cell (5, 10, 1): centre (22, 42, 1.5), open ground north of the house.
  EXPECT_EQ(grid.at(5, 10, 1), 1);
  EXPECT_EQ(stats.cells_nearest + stats.cells_farther + stats.cells_inside + stats.cells_searched + stats.cells_unseen, size_t(kGridCells));
}

TEST(IndexGrid, ExtentCoversTheProbesAndTheGround) {
  IndexGrid grid;
  const std::vector<glm::vec3> probes = {{1, 1, 10.f}, {2, 2, 30.f}};
  chooseGridExtent(probes, 5.f, grid);
  EXPECT_LE(grid.z_min_m, 5.f - 2.f);
  EXPECT_GE(grid.z_min_m + 16.f * grid.cell_height_m, 30.f + 4.f);
  chooseGridExtent({}, INFINITY, grid);
  EXPECT_GE(grid.cell_height_m, kMinCellHeightM);
}

}  // namespace
}  // namespace drtv::baker
