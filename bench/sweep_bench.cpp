// drtv_sweep_bench — the top-down sweep (drtv::sweep) on one core. Goals (issue 15): one 64 m x
// 64 m sector at 1 m cells swept <= 10 ms; the 16 m grid of a 1 km^2 island <= 50 ms; the bytes
// of each grid as counters. The material is synthetic and deterministic, shaped like the island
// (docs/sweep.md): rolling ground, and tree crowns of density 0.3 per cell with trunks, on 30 %
// of the ground; 32 levels for a sector (0-32 m: its ground lies 5.4-10 m up and its crowns reach
// 22.5 m; the technique would size this sector's grid 4-25 m, one cell under the lowest ground and
// two over the tallest crown, docs/sweep.md), 6 for the island (-32..64 m at 16 m). Its lowest
// levels are sealed ground (sweep.h), which the sweep skips.
// Run a Release build: drtv_sweep_bench --benchmark_min_time=0.5
#include <benchmark/benchmark.h>

#include <cmath>

#include "drtv/sweep/sweep.h"

namespace drtv::sweep {
namespace {

double groundM(double x, double y) { return 6.0 + 4.0 * std::sin(x * 0.031) * std::cos(y * 0.027); }

// Trees on a 10 m lattice where a hash says so: crown radius 3.5 m around 9 m, trunk to the ground.
float treeDensity(double x, double y, double z, double cell_m) {
  const double gx = std::floor(x / 10.0), gy = std::floor(y / 10.0);
  const uint32_t h = uint32_t(int64_t(gx) * 73856093) ^ uint32_t(int64_t(gy) * 19349663);
  if (h % 10 >= 3) return 0.f;
  const double cx = gx * 10 + 5, cy = gy * 10 + 5, cz = groundM(cx, cy) + 9.0;
  const double r = std::sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz));
  if (r < 3.5) return float(1.0 - std::pow(0.7, cell_m));
  if (std::abs(x - cx) < 0.5 * cell_m && std::abs(y - cy) < 0.5 * cell_m && z < cz) return std::min(1.f, float(0.4 / cell_m));
  return 0.f;
}

MaterialGrid makeMaterial(const GridShape& s) {
  MaterialGrid m = MaterialGrid::clear(s);
  for (int k = 0; k < s.size.z; ++k)
    for (int j = 0; j < s.size.y; ++j)
      for (int i = 0; i < s.size.x; ++i) {
        const glm::dvec3 c = s.centre(i, j, k);
        const size_t n = s.index(i, j, k);
        const double below = std::clamp((groundM(c.x, c.y) - (c.z - 0.5 * s.cell_m)) / s.cell_m, 0.0, 1.0);
        const float tree = treeDensity(c.x, c.y, c.z, s.cell_m);
        m.density[n] = float(1.0 - (1.0 - below) * (1.0 - tree));
        m.reflectance[n] = below > 0 ? glm::vec3(0.25f, 0.35f, 0.15f) : glm::vec3(0.1f, 0.3f, 0.08f);
      }
  return m;
}

SkyInput morning() {
  const Sky sky = Sky::tropicalDefault();
  return {skyLight(sky, 9.0), sunLight(sky, 9.0, 0.05)};
}

// `refill`: every iteration sweeps into the same grid (sweepInto, as a re-sweep under new lighting
// does), not into a fresh one.
void run(benchmark::State& state, const GridShape& shape, const SweptGrid* parent, SweepOptions o, bool refill = false) {
  const MaterialGrid m = makeMaterial(shape);
  const SkyInput sky = morning();
  size_t bytes = 0;
  SweptGrid kept;
  for (auto _ : state) {
    if (refill) {
      sweepInto(m, sky, parent, o, kept);
      bytes = kept.bytes();
      benchmark::DoNotOptimize(kept.light.light.data());
    } else {
      SweptGrid g = sweep(m, sky, parent, o);
      bytes = g.bytes();
      benchmark::DoNotOptimize(g.light.light.data());
    }
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(shape.cellCount()));
  state.counters["cells"] = double(shape.cellCount());
  state.counters["grid_bytes"] = double(bytes);
  state.counters["material_bytes"] = double(shape.cellCount() * (sizeof(float) + sizeof(glm::vec3)));
}

const GridShape kSector{{0.0, 0.0, 0.0}, 1.0, {64, 64, 32}};
const GridShape kIsland{{-512.0, -512.0, -32.0}, 16.0, {64, 64, 6}};

void BM_SweepSector1m(benchmark::State& state) { run(state, kSector, nullptr, {}); }
BENCHMARK(BM_SweepSector1m)->Unit(benchmark::kMillisecond);

// The same sector's ground and trees in the grid the technique would give it (4-25 m: one cell
// under its lowest ground, two over its tallest crown), re-swept: fewer levels, fewer of them
// sealed.
void BM_ResweepSector1mAsTheTechniqueSizesIt(benchmark::State& state) {
  run(state, GridShape{{0.0, 0.0, 4.0}, 1.0, {64, 64, 21}}, nullptr, {}, true);
}
BENCHMARK(BM_ResweepSector1mAsTheTechniqueSizesIt)->Unit(benchmark::kMillisecond);

// The same sector re-swept into the grid of the sweep before (sweepInto).
void BM_ResweepSector1m(benchmark::State& state) { run(state, kSector, nullptr, {}, true); }
BENCHMARK(BM_ResweepSector1m)->Unit(benchmark::kMillisecond);

void BM_SweepSector1mBottomUp(benchmark::State& state) {
  SweepOptions o;
  o.bottom_up = true;
  run(state, kSector, nullptr, o);
}
BENCHMARK(BM_SweepSector1mBottomUp)->Unit(benchmark::kMillisecond);

// The sector with its edges from the island's 16 m grid, as the technique sweeps it.
void BM_SweepSector1mUnderCoarse(benchmark::State& state) {
  SweepOptions co;
  co.keep_direct = true;
  const SweptGrid coarse = sweep(makeMaterial(kIsland), morning(), nullptr, co);
  run(state, kSector, &coarse, {});
}
BENCHMARK(BM_SweepSector1mUnderCoarse)->Unit(benchmark::kMillisecond);

void BM_SweepIsland16m(benchmark::State& state) {
  SweepOptions o;
  o.keep_direct = true;  // the coarse grid keeps the sun's part for the fine grids' edges
  run(state, kIsland, nullptr, o);
}
BENCHMARK(BM_SweepIsland16m)->Unit(benchmark::kMillisecond);

void BM_SkyAndSunBins(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(morning());
}
BENCHMARK(BM_SkyAndSunBins)->Unit(benchmark::kMillisecond);

void BM_AmbientLookup(benchmark::State& state) {
  const SweptGrid g = sweep(makeMaterial(kSector), morning(), nullptr, {});
  double x = 0.3;
  for (auto _ : state) {
    x = x + 0.618;
    if (x > 63) x -= 63;
    benchmark::DoNotOptimize(g.light.ambient({x, 64 - x, 12.0}, {0.f, 0.6f, 0.8f}));
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_AmbientLookup);

}  // namespace
}  // namespace drtv::sweep

BENCHMARK_MAIN();
