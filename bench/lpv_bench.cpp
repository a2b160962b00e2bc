// Benchmarks of the cascaded light propagation volumes (drtv/lpv/lpv.h, issue 14; figures in
// docs/lpv.md). The library alone, with RSM texels made here (in an engine they come from the
// GPU); the technique's ray-cast RSMs are timed by `drtv accuracy` (its "relight + fill" column).
#include <benchmark/benchmark.h>

#include <cmath>
#include <utility>
#include <vector>

#include "drtv/lpv/lpv.h"

namespace {

using drtv::lpv::CascadedLpv;
using drtv::lpv::LpvOptions;
using drtv::lpv::Surfel;

// A 256 x 256 RSM's texels over a rolling ground around the camera, and its occluders.
std::vector<Surfel> groundRsm(double extent_m, int res) {
  std::vector<Surfel> out;
  const double texel = extent_m / res;
  for (int j = 0; j < res; ++j)
    for (int i = 0; i < res; ++i) {
      const double x = -extent_m / 2 + (i + 0.5) * texel, y = -extent_m / 2 + (j + 0.5) * texel;
      const double z = 2.0 * std::sin(x * 0.1) * std::cos(y * 0.13);
      const glm::vec3 n = glm::normalize(glm::vec3(-0.2f * std::cos(float(x) * 0.1f), 0.26f * std::sin(float(y) * 0.13f), 1.f));
      out.push_back({glm::dvec3(x, y, z), n, glm::vec3(0.3f, 0.25f, 0.2f) * float(texel * texel), float(texel * texel)});
    }
  return out;
}

// The benchmarks' scene: 3 cascades around the origin, each with one 256 x 256 RSM over its box;
// with `occluders`, the RSM's surfels also fill the geometry volume and its transmittances (made
// once, as for a still camera).
struct Scene {
  CascadedLpv lpv;
  std::vector<std::vector<Surfel>> rsm;
};
Scene makeScene(const LpvOptions& o, bool occluders) {
  Scene s{std::move(*CascadedLpv::create(o)), {}};
  s.lpv.setCamera(glm::dvec3(0.0));
  for (int c = 0; c < 3; ++c) {
    s.rsm.push_back(groundRsm(s.lpv.box(c).cell_m * o.cells, 256));
    if (!occluders) continue;
    s.lpv.injectGeometry(c, s.rsm.back());
    s.lpv.computeOcclusion(c);
  }
  return s;
}

// A full update: injection of one 256 x 256 RSM per cascade, 8 iterations on 3 cascades of 32^3,
// occlusion on (the geometry volume and transmittances made once, as for a still camera), in one
// relight() call. One cell is read after it (cellLight), so that the update is not optimised away;
// the test helper totalLight, which sums a whole cascade, is no part of an update and is not timed.
void BM_LpvInjectAndPropagate(benchmark::State& state) {
  LpvOptions o;
  o.iterations = int(state.range(0));
  o.threads = int(state.range(1));
  Scene s = makeScene(o, true);
  CascadedLpv* lpv = &s.lpv;
  std::vector<drtv::lpv::VplList> lists;
  for (int c = 0; c < 3; ++c) lists.push_back({c, s.rsm[size_t(c)]});
  for (auto _ : state) {
    lpv->relight(lists);
    benchmark::DoNotOptimize(lpv->cellLight(0, 16, 16, 16));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * 3 * o.cells * o.cells * o.cells * o.iterations);
  state.counters["bytes"] = double(lpv->bytes());
}
BENCHMARK(BM_LpvInjectAndPropagate)->Args({8, 1})->Args({8, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

// The same update made by the calls per cascade (clearLight, injectLight, propagate: each
// injection and propagation wakes the workers), for comparison with relight().
void BM_LpvInjectAndPropagateByCascade(benchmark::State& state) {
  LpvOptions o;
  o.iterations = int(state.range(0));
  o.threads = int(state.range(1));
  Scene s = makeScene(o, true);
  CascadedLpv* lpv = &s.lpv;
  for (auto _ : state) {
    for (int c = 0; c < 3; ++c) {
      lpv->clearLight(c);
      lpv->injectLight(c, s.rsm[size_t(c)]);
      lpv->propagate(c);
    }
    benchmark::DoNotOptimize(lpv->cellLight(0, 16, 16, 16));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * 3 * o.cells * o.cells * o.cells * o.iterations);
}
BENCHMARK(BM_LpvInjectAndPropagateByCascade)->Args({8, 1})->Args({8, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

// The propagation alone (8 steps on 3 cascades), the light injected once.
void BM_LpvPropagate(benchmark::State& state) {
  LpvOptions o;
  o.threads = int(state.range(0));
  Scene s = makeScene(o, true);
  CascadedLpv* lpv = &s.lpv;
  for (int c = 0; c < 3; ++c) lpv->injectLight(c, s.rsm[size_t(c)]);
  for (auto _ : state) {
    for (int c = 0; c < 3; ++c) lpv->propagate(c);
    benchmark::DoNotOptimize(lpv->cellLight(0, 16, 16, 16));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * 3 * o.cells * o.cells * o.cells * o.iterations);
}
BENCHMARK(BM_LpvPropagate)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The injection alone: one 256 x 256 RSM per cascade (cleared first), as in a full update.
void BM_LpvInject(benchmark::State& state) {
  LpvOptions o;
  o.threads = int(state.range(0));
  Scene s = makeScene(o, false);
  CascadedLpv* lpv = &s.lpv;
  for (auto _ : state) {
    for (int c = 0; c < 3; ++c) {
      lpv->clearLight(c);
      lpv->injectLight(c, s.rsm[size_t(c)]);
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * 3 * 256 * 256);
}
BENCHMARK(BM_LpvInject)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// totalLight(0), the test helper the update's benchmarks summed after each update until
// relight() came (so that their earlier figures can be compared with these).
void BM_LpvTotalLight(benchmark::State& state) {
  LpvOptions o;
  auto lpv = CascadedLpv::create(o);
  lpv->setCamera(glm::dvec3(0.0));
  const std::vector<Surfel> rsm = groundRsm(lpv->box(0).cell_m * o.cells, 256);
  lpv->injectLight(0, rsm);
  lpv->propagate(0);
  for (auto _ : state) benchmark::DoNotOptimize(lpv->totalLight(0));
}
BENCHMARK(BM_LpvTotalLight)->Unit(benchmark::kMillisecond);

// One camera step of one cell: the finest cascade moves, its geometry volume, transmittances, sky
// and light are made again and propagated (relight; the coarser ones stay). One cell is read after.
void BM_LpvCameraStep(benchmark::State& state) {
  LpvOptions o;
  auto lpv = CascadedLpv::create(o);
  const std::vector<Surfel> ground = groundRsm(128.0, 512);
  double x = 0.0;
  lpv->setCamera(glm::dvec3(x, 0, 0));
  for (auto _ : state) {
    x += o.cell_m;
    const uint32_t moved = lpv->setCamera(glm::dvec3(std::fmod(x, 32.0), 0, 0));
    for (int c = 0; c < 3; ++c) {
      if (!(moved & (1u << c))) continue;
      lpv->injectGeometry(c, ground);
      lpv->computeOcclusion(c);
      lpv->computeSky(c, [](const glm::vec3& w) { return glm::vec3(std::max(0.1f, w.z)); });
      const drtv::lpv::VplList list{c, ground};
      lpv->relight({&list, 1});
    }
    benchmark::DoNotOptimize(lpv->cellLight(0, 16, 16, 16));
  }
}
BENCHMARK(BM_LpvCameraStep)->Unit(benchmark::kMillisecond);

// The lookup a deferred pass makes per pixel: indirect plus sky.
void BM_LpvAmbientLookup(benchmark::State& state) {
  LpvOptions o;
  auto lpv = CascadedLpv::create(o);
  lpv->setCamera(glm::dvec3(0.0));
  double x = 0;
  for (auto _ : state) {
    x = x > 40 ? -40 : x + 0.37;
    const glm::dvec3 p(x, 0.5 * x, 1.0);
    benchmark::DoNotOptimize(lpv->indirect(p, glm::vec3(0, 0, 1)) + lpv->sky(p, glm::vec3(0, 0, 1)));
  }
  state.SetItemsProcessed(int64_t(state.iterations()));
}
BENCHMARK(BM_LpvAmbientLookup);

}  // namespace

BENCHMARK_MAIN();
