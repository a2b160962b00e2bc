// The sweep's 1 m material grids (issue 15), one core: every triangle ray cast per sector
// (sweep_material.h, material=raycast) against the placed models voxelised once with OpenVDB and
// resampled, the rest (terrain, large meshes) ray cast (model_material.h, material=models).
// Each benchmark makes the grids of a block of sectors as the technique does (the shape from the
// sector's gathered height range) and reports per sector. The models' comparison benchmarks also
// report, as counters, per-cell differences of the models' grids from the ray-cast ones over the
// cells where either has material: mean and max |density difference|, the share of those cells
// differing by more than 0.25, the ratio of total densities, and the mean |reflectance
// difference| (max channel) over cells where both have material.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>

#include "../eval/techniques/sweep/model_material.h"
#include "../eval/techniques/sweep/sweep_material.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/sweep/directions.h"
#include "drtv/sweep/sweep.h"
#include "drtv/worlds/load.h"

namespace drtv::eval {
namespace {

[[noreturn]] void die(const std::string& m) {
  std::fprintf(stderr, "%s\n", m.c_str());
  std::exit(1);
}

struct Scene {
  worlds::World world, rest;
  std::optional<raytrace::WorldGeometry> geo, rest_geo;
  std::optional<ModelMaterial> models;
  std::vector<sweep::GridShape> shapes;  // the block's fine grids
};

const Scene& sceneOf(const std::string& file, raytrace::SectorRange block, double voxel_m = ModelVoxelOptions{}.voxel_m) {
  static std::map<std::tuple<std::string, double, int32_t, int32_t, int32_t, int32_t>, std::unique_ptr<Scene>> cache;
  auto& slot = cache[{file, voxel_m, block.x0, block.x1, block.y0, block.y1}];
  if (slot) return *slot;
  slot = std::make_unique<Scene>();
  Scene& s = *slot;
  auto w = worlds::loadWorld(std::string(DRTV_SOURCE_DIR) + "/" + file);
  if (!w) die(w.error().message);
  s.world = std::move(*w);
  auto g = raytrace::WorldGeometry::build(s.world, file);
  if (!g) die(g.error().message);
  s.geo = std::move(*g);
  auto m = ModelMaterial::build(s.world, {voxel_m});
  if (!m) die(m.error().message);
  s.models = std::move(*m);
  s.rest.meshes = s.world.meshes;
  for (const auto& inst : s.world.instances)
    if (!placedAsModel(s.world, inst)) s.rest.instances.push_back(inst);
  auto rg = raytrace::WorldGeometry::build(s.rest, file);
  if (!rg) die(rg.error().message);
  s.rest_geo = std::move(*rg);
  const VoxelOptions vo;
  for (int32_t y = block.y0; y <= block.y1; ++y)
    for (int32_t x = block.x0; x <= block.x1; ++x) {
      const raytrace::SectorGeometry sg = s.geo->gather({x, y}, vo.halo_m);
      if (sg.triangleCount() == 0) continue;
      const double lo = std::floor(double(sg.z_min)) - 1, hi = std::ceil(double(sg.z_max)) + 2;
      s.shapes.push_back({{64.0 * x, 64.0 * y, lo}, 1.0, {64, 64, int(std::lround(hi - lo))}});
    }
  std::fprintf(stderr, "%s, voxel %.3f m: %zu models, %zu placements, %zu voxels, voxelised in %.3f s\n", file.c_str(), voxel_m, s.models->stats().models,
               s.models->stats().placements, s.models->stats().voxels, s.models->stats().build_s);
  return s;
}

const raytrace::SectorRange kIslandBlock{-1, 1, -1, 1}, kTestboxBlock{-1, 0, -1, 0};

sweep::MaterialGrid rayCast(const Scene& s, const sweep::GridShape& shape) {
  auto m = voxelise(*s.geo, shape, {});
  if (!m) die(m.error().message);
  return std::move(*m);
}

sweep::MaterialGrid fromModels(const Scene& s, const sweep::GridShape& shape) {
  const ObjectLayer objects = s.models->resample(shape);
  auto m = voxelise(&*s.rest_geo, shape, {}, nullptr, &objects);
  if (!m) die(m.error().message);
  return std::move(*m);
}

void perSector(benchmark::State& state, const Scene& s) {
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(s.shapes.size()));
  state.counters["sectors"] = double(s.shapes.size());
}

void rayCastBlock(benchmark::State& state, const std::string& file, raytrace::SectorRange block) {
  const Scene& s = sceneOf(file, block);
  for (auto _ : state)
    for (const auto& shape : s.shapes) benchmark::DoNotOptimize(rayCast(s, shape));
  perSector(state, s);
}

void modelsBlock(benchmark::State& state, const std::string& file, raytrace::SectorRange block, double voxel_m = ModelVoxelOptions{}.voxel_m) {
  const Scene& s = sceneOf(file, block, voxel_m);
  for (auto _ : state)
    for (const auto& shape : s.shapes) benchmark::DoNotOptimize(fromModels(s, shape));
  perSector(state, s);
  // The comparison, once.
  double n = 0, sum_abs = 0, max_abs = 0, over = 0, sum_rays = 0, sum_models = 0, both = 0, refl = 0;
  for (const auto& shape : s.shapes) {
    const sweep::MaterialGrid a = rayCast(s, shape), b = fromModels(s, shape);
    for (size_t c = 0; c < shape.cellCount(); ++c) {
      const double da = a.density[c], db = b.density[c];
      if (da == 0 && db == 0) continue;
      const double d = std::abs(da - db);
      ++n;
      sum_abs += d;
      max_abs = std::max(max_abs, d);
      over += d > 0.25;
      sum_rays += da;
      sum_models += db;
      if (da > 0 && db > 0) {
        const glm::vec3 r = glm::abs(a.reflectance[c] - b.reflectance[c]);
        refl += std::max({r.x, r.y, r.z});
        ++both;
      }
    }
  }
  state.counters["cells"] = n;
  state.counters["mean_abs_d"] = sum_abs / n;
  state.counters["max_abs_d"] = max_abs;
  state.counters["share_over_0.25"] = over / n;
  state.counters["density_ratio"] = sum_models / sum_rays;
  state.counters["mean_abs_refl"] = both > 0 ? refl / both : 0.0;
}

void resampleBlock(benchmark::State& state, const std::string& file, raytrace::SectorRange block, double voxel_m = ModelVoxelOptions{}.voxel_m) {
  const Scene& s = sceneOf(file, block, voxel_m);
  for (auto _ : state)
    for (const auto& shape : s.shapes) benchmark::DoNotOptimize(s.models->resample(shape));
  perSector(state, s);
}

void restRayCastBlock(benchmark::State& state, const std::string& file, raytrace::SectorRange block) {
  const Scene& s = sceneOf(file, block);
  for (auto _ : state)
    for (const auto& shape : s.shapes) {
      auto m = voxelise(*s.rest_geo, shape, {});
      benchmark::DoNotOptimize(m);
    }
  perSector(state, s);
}

void BM_IslandRayCast(benchmark::State& st) { rayCastBlock(st, "worlds/island.json", kIslandBlock); }
// The argument: the model voxels' edge, millimetres (ModelVoxelOptions::voxel_m).
void BM_IslandModels(benchmark::State& st) { modelsBlock(st, "worlds/island.json", kIslandBlock, 1e-3 * double(st.range(0))); }
void BM_IslandModelsResampleOnly(benchmark::State& st) {
  resampleBlock(st, "worlds/island.json", kIslandBlock, 1e-3 * double(st.range(0)));
}
void BM_IslandTerrainAndLargeRayCastOnly(benchmark::State& st) { restRayCastBlock(st, "worlds/island.json", kIslandBlock); }
void BM_TestboxRayCast(benchmark::State& st) { rayCastBlock(st, "worlds/fc3_testbox.json", kTestboxBlock); }
void BM_TestboxModels(benchmark::State& st) { modelsBlock(st, "worlds/fc3_testbox.json", kTestboxBlock); }
BENCHMARK(BM_IslandRayCast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IslandModels)->Arg(125)->Arg(250)->Arg(500)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IslandModelsResampleOnly)->Arg(125)->Arg(250)->Arg(500)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IslandTerrainAndLargeRayCastOnly)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TestboxRayCast)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TestboxModels)->Unit(benchmark::kMillisecond);

// The sweep itself on the island's own 1 m grids, every sector of the world that has geometry
// (their material ray cast once, outside the timing), each re-swept into its grid of the sweep
// before as the grid streamer does, under the sky edges at 9:00: the figure the synthetic
// 64 x 64 x 32 sector of drtv_sweep_bench stands for, per sector, with the levels the technique
// gives each sector (two cells of air above its tallest geometry, one below its lowest).
void BM_IslandSectorsResweep(benchmark::State& state) {
  const std::string file = "worlds/island.json";
  static const Scene& whole = [&]() -> const Scene& {
    auto w = worlds::loadWorld(std::string(DRTV_SOURCE_DIR) + "/" + file);
    if (!w) die(w.error().message);
    auto g = raytrace::WorldGeometry::build(*w, file);
    if (!g) die(g.error().message);
    return sceneOf(file, g->sectors());
  }();
  static const std::vector<sweep::MaterialGrid> materials = [&] {
    std::vector<sweep::MaterialGrid> m;
    for (const auto& shape : whole.shapes) m.push_back(rayCast(whole, shape));
    return m;
  }();
  const sweep::SkyInput sky{sweep::skyLight(whole.world.sky, 9.0), sweep::sunLight(whole.world.sky, 9.0, 0.05)};
  std::vector<sweep::SweptGrid> grids(materials.size());
  for (size_t i = 0; i < materials.size(); ++i) grids[i] = sweep::sweep(materials[i], sky, nullptr, {});
  for (auto _ : state)
    for (size_t i = 0; i < materials.size(); ++i) {
      sweep::sweepInto(materials[i], sky, nullptr, {}, grids[i]);
      benchmark::DoNotOptimize(grids[i].light.light.data());
    }
  perSector(state, whole);
  double levels = 0, most = 0, cells = 0;
  for (const auto& shape : whole.shapes) {
    levels += shape.size.z;
    most = std::max(most, double(shape.size.z));
    cells += double(shape.cellCount());
  }
  state.counters["mean_levels"] = levels / double(whole.shapes.size());
  state.counters["most_levels"] = most;
  // Each sector's own time, the least of 3 re-sweeps, and its levels: the spread behind the mean
  // (items_per_second is sectors a second).
  std::vector<std::pair<double, int>> per;
  for (size_t i = 0; i < materials.size(); ++i) {
    double best = 1e30;
    for (int r = 0; r < 3; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      sweep::sweepInto(materials[i], sky, nullptr, {}, grids[i]);
      best = std::min(best, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    per.push_back({best, whole.shapes[i].size.z});
  }
  std::sort(per.begin(), per.end());
  const auto at = [&](double q) { return per[std::min(per.size() - 1, size_t(q * double(per.size())))]; };
  state.counters["p50_ms"] = at(0.5).first;
  state.counters["p90_ms"] = at(0.9).first;
  state.counters["max_ms"] = per.back().first;
  state.counters["max_ms_levels"] = per.back().second;
  state.counters["share_over_10ms"] = double(std::count_if(per.begin(), per.end(), [](const auto& p) { return p.first > 10.0; })) / double(per.size());
}
BENCHMARK(BM_IslandSectorsResweep)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drtv::eval

BENCHMARK_MAIN();
