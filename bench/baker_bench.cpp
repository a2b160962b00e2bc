// Placement and the index grid, one sector at a time (issue 16: "benchmarks for placement and index
// grid per sector"): the island's centre sector, and the sector of tests/reference/data/facade.json
// that holds most of its building (four balconies over a 15 m facade). Each iteration is what the
// bake does for that sector: placeProbes on the sector's gathered scene, or chooseGridExtent +
// fillIndexGrid over the probes it placed. One thread (the bake runs sectors in parallel).
#include <benchmark/benchmark.h>

#include <tbb/global_control.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "drtv/baker/bake.h"
#include "drtv/baker/index_grid.h"
#include "drtv/baker/placement.h"
#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/worlds/load.h"

namespace {
using namespace drtv;

struct SectorScene {
  raytrace::SectorGeometry geometry;
  std::unique_ptr<raytrace::RayScene> scene;
  std::vector<glm::vec3> probes;  // what placement gives, for the index grid
};

const SectorScene& sectorOf(const std::string& world_file, SectorKey key) {
  static std::map<std::string, std::unique_ptr<SectorScene>> cache;
  auto& slot = cache[world_file];
  if (slot) return *slot;
  auto world = worlds::loadWorld(std::string(DRTV_SOURCE_DIR) + "/" + world_file);
  if (!world) {
    std::fprintf(stderr, "%s\n", world.error().message.c_str());
    std::exit(1);
  }
  const baker::BakeSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDefault, 1);
  auto geometry = raytrace::WorldGeometry::build(*world, world_file);
  if (!geometry) {
    std::fprintf(stderr, "%s\n", geometry.error().message.c_str());
    std::exit(1);
  }
  slot = std::make_unique<SectorScene>();
  slot->geometry = geometry->gather(key, settings.halo_m);
  auto scene = raytrace::RayScene::build(slot->geometry.vertices, slot->geometry.twoSided());
  if (!scene) {
    std::fprintf(stderr, "%s\n", scene.error().message.c_str());
    std::exit(1);
  }
  slot->scene = std::make_unique<raytrace::RayScene>(std::move(*scene));
  baker::PlacementStats stats;
  for (const baker::PlacedProbe& p : baker::placeProbes(*slot->scene, slot->geometry, {0, 0}, {}, settings.placement, stats))
    slot->probes.push_back(p.position);
  return *slot;
}

void placement(benchmark::State& state, const std::string& world, SectorKey key) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const SectorScene& s = sectorOf(world, key);
  const baker::PlacementSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDefault, 1).placement;
  size_t probes = 0;
  for (auto _ : state) {
    baker::PlacementStats stats;
    const auto placed = baker::placeProbes(*s.scene, s.geometry, {0, 0}, {}, settings, stats);
    probes = placed.size();
    benchmark::DoNotOptimize(placed.data());
  }
  state.counters["probes"] = double(probes);
  state.counters["triangles"] = double(s.geometry.vertices.size() / 3);
}

void indexGrid(benchmark::State& state, const std::string& world, SectorKey key) {
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  const SectorScene& s = sectorOf(world, key);
  const baker::IndexGridSettings settings = baker::BakeSettings::forQuality(baker::Quality::kDefault, 1).grid;
  auto grid = std::make_unique<IndexGrid>();
  uint64_t rays = 0;
  for (auto _ : state) {
    baker::IndexGridStats stats;
    baker::chooseGridExtent(s.probes, INFINITY, *grid);
    baker::fillIndexGrid(*s.scene, s.probes, settings, *grid, stats);
    rays = stats.rays;
    benchmark::DoNotOptimize(grid->cells.data());
  }
  state.counters["probes"] = double(s.probes.size());
  state.counters["rays"] = double(rays);
}

BENCHMARK_CAPTURE(placement, island, std::string("worlds/island.json"), SectorKey{0, 0})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(placement, facade, std::string("tests/reference/data/facade.json"), SectorKey{-1, -1})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(indexGrid, island, std::string("worlds/island.json"), SectorKey{0, 0})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(indexGrid, facade, std::string("tests/reference/data/facade.json"), SectorKey{-1, -1})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
