// drtv_runtime_bench — the runtime's hot paths on the talk's budget: 51 resident sectors of 70
// probes (3,570 probes), a 96x96x16 volume. Goals (issue "Runtime", 2-core host): relight
// without LPRT <= 15 us, with LPRT <= 0.5 ms; full refill <= 0.35 ms; a one-texel scroll <= 1/50
// of a full refill. Run a Release build: drtv_runtime_bench --benchmark_min_time=0.2
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/runtime.h"
#include "refill_loop.h"
#include "runtime_world.h"  // bench/common: the synthetic sectors the tests use too

namespace drtv::runtime {
namespace {

std::vector<SectorKey> residentKeys() {
  std::vector<SectorKey> keys;
  for (int y = -3; y <= 3; ++y)
    for (int x = -3; x <= 3; ++x) keys.push_back({x, y});
  keys.push_back({4, 0});
  keys.push_back({-4, 0});
  return keys;  // 51
}

// `sun_transfer`: sh-l1 of archive version 3 (the fitted direct sky and a 6-sample sun transfer)
// instead of version 2.
ProbeCache makeCache(int sources, int sources_per_light = 4, LightSources light_sources = LightSources::kVisibleFromLight,
                     Representation r = Representation::kFc3, bool sun_transfer = false) {
  ProbeCache cache({.max_sectors = kMaxResidentSectors, .sources_per_light = sources_per_light, .light_sources = light_sources,
                    .representation = r});
  const bool sh_l1 = r == Representation::kShL1;
  for (SectorKey k : residentKeys())
    if (!cache.addSector(testing::makeSector(k, {.probes = 70, .sources = sources, .lprt_on_bases = !sh_l1,
                                                 .sky_moments = sh_l1 && !sun_transfer, .sky_fit = sh_l1 && sun_transfer,
                                                 .sun_samples = sh_l1 && sun_transfer ? 6 : 0}, 1)))
      std::abort();
  return cache;
}

RelightInput noonInput(std::span<const PointLight> lights = {}) {
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 12.0);
  RelightInput in{s.sky_sh, s.sun_sh, s.sky_direct_sh, lights, kAllComponents};
  in.sun_direction = s.sun_direction;
  in.sun_irradiance = s.sun_irradiance;
  in.sun_transfer = true;  // used only by sectors that have one
  return in;
}

void BM_EvaluateSky(benchmark::State& state) {
  const Sky sky = Sky::tropicalDefault();
  double hour = 6.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(evaluateSky(sky, hour));
    hour += 0.001;
  }
}
BENCHMARK(BM_EvaluateSky);

// Arg: the representation (0 fc3, 1 sh-l1; representation.h), side by side in one run.
// Arg 0: fc3; 1: sh-l1 of archive version 2; 2: sh-l1 of version 3 (its sun transfer).
void BM_RelightWithoutLprt(benchmark::State& state) {
  ProbeCache cache =
      makeCache(0, 4, LightSources::kVisibleFromLight, state.range(0) ? Representation::kShL1 : Representation::kFc3, state.range(0) == 2);
  const RelightInput in = noonInput();
  for (auto _ : state) {
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
  state.counters["probes"] = cache.probeCount();
}
BENCHMARK(BM_RelightWithoutLprt)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

// LPRT baked (128 sources per sector, ~11 MB of coefficients) with `lights` lights of 12 m.
void BM_RelightWithLprt(benchmark::State& state) {
  ProbeCache cache = makeCache(128);
  std::vector<PointLight> lights;
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-200.0, 200.0);
  for (int i = 0; i < state.range(0); ++i) lights.push_back({"l", {u(rng), u(rng), 12.0}, glm::vec3(2.f), 12.f});
  const RelightInput in = noonInput(lights);
  for (auto _ : state) {
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
}
BENCHMARK(BM_RelightWithLprt)->Arg(0)->Arg(8)->Arg(32)->Unit(benchmark::kMicrosecond);

// 32 lights on circles of 20-180 m at 100 m/s, 12 m up (vehicles), at frame `frame` (60 Hz).
struct Movers {
  std::vector<PointLight> lights = std::vector<PointLight>(32);
  std::vector<double> phase = std::vector<double>(32), radius = std::vector<double>(32);
  Movers() {
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (size_t i = 0; i < lights.size(); ++i) {
      lights[i] = {"mover", {}, glm::vec3(2.f), 12.f};
      phase[i] = 6.283185307 * u(rng);
      radius[i] = 20.0 + 160.0 * u(rng);
    }
  }
  const std::vector<PointLight>& at(int frame) {
    const double t = frame / 60.0;
    for (size_t i = 0; i < lights.size(); ++i) {
      const double a = phase[i] + 100.0 * t / radius[i];
      lights[i].position = {radius[i] * std::cos(a), radius[i] * std::sin(a), 12.0};
    }
    return lights;
  }
};

// 32 lights that move every frame: each frame redistributes them onto the source probes near
// their new positions and relights everything.
void BM_RelightWith32MovingLights(benchmark::State& state) {
  ProbeCache cache = makeCache(128);
  Movers m;
  int frame = 0;
  for (auto _ : state) {
    cache.relightAll(noonInput(m.at(frame++)));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
}
BENCHMARK(BM_RelightWith32MovingLights)->Unit(benchmark::kMicrosecond);

// The same movers, relighting only the sectors whose sources' shares changed (what
// Runtime::update does when the lights alone moved). Counter: sectors relit per frame.
void BM_RelightChangedWith32MovingLights(benchmark::State& state) {
  ProbeCache cache = makeCache(128);
  Movers m;
  int frame = 0;
  cache.relightAll(noonInput(m.at(frame++)));
  const uint64_t before = cache.slotRelightCount();
  for (auto _ : state) {
    benchmark::DoNotOptimize(cache.relightChangedLights(noonInput(m.at(frame++))));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
  state.counters["sectors_relit"] = double(cache.slotRelightCount() - before) / double(state.iterations());
}
BENCHMARK(BM_RelightChangedWith32MovingLights)->Unit(benchmark::kMicrosecond);

// What the fly over the lit island asks of the relight every frame at 0.2 h/s (60 Hz: 1/300 h a
// frame, past the relight threshold every frame): every probe relit (relightAll) at a new hour,
// with the LPRT lights of the frame. Args: the 32 movers still (0: an hour change alone) or moving
// (1); fc3 with LPRT on bases (0) or the island's sh-l1 with a sun transfer and LPRT in SH (1).
void BM_RelightHourChangeWithLprt(benchmark::State& state) {
  const bool sh_l1 = state.range(1) != 0;
  ProbeCache cache = makeCache(128, 4, LightSources::kVisibleFromLight, sh_l1 ? Representation::kShL1 : Representation::kFc3, sh_l1);
  Movers m;
  const Sky sky = Sky::tropicalDefault();
  int frame = 0;
  double hour = 8.0;
  std::vector<PointLight> lights = m.at(frame);
  for (auto _ : state) {
    hour += 0.2 / 60.0;
    if (state.range(0)) lights = m.at(++frame);
    const SkyLighting s = sh_l1 ? evaluateSky(sky, hour, kLinearSunBand1, 0.f) : evaluateSky(sky, hour);
    RelightInput in{s.sky_sh, s.sun_sh, s.sky_direct_sh, lights, kAllComponents};
    in.sun_direction = s.sun_direction;
    in.sun_irradiance = s.sun_irradiance;
    in.sun_transfer = sh_l1;
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
}
BENCHMARK(BM_RelightHourChangeWithLprt)->Args({0, 0})->Args({1, 0})->Args({0, 1})->Args({1, 1})->Unit(benchmark::kMicrosecond);

// A whole frame of the engine with the 32 movers and the time of day standing still:
// Runtime::setLights + update (relight, pack, refill the back buffer's changed texels, publish),
// the camera still. Arg: blur (the lit island's volume is blurred).
void BM_RuntimeFrameWith32MovingLights(benchmark::State& state) {
  RuntimeOptions o;
  o.volume.blur = state.range(0) != 0;
  Runtime rt(o);
  for (SectorKey k : residentKeys())
    if (!rt.addSector(testing::makeSector(k, {.probes = 70, .sources = 128}, 1))) std::abort();
  (void)rt.setTime(12.0);
  Movers m;
  int frame = 0;
  (void)rt.setLights(m.at(frame++));
  rt.update({0.0, 0.0, 12.0});
  uint64_t texels = 0;
  for (auto _ : state) {
    (void)rt.setLights(m.at(frame++));
    rt.update({0.0, 0.0, 12.0});
    texels += rt.volume().lastUpdateTexels();
  }
  state.counters["texels"] = double(texels) / double(state.iterations());
}
BENCHMARK(BM_RuntimeFrameWith32MovingLights)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// One sector streaming in, as the fly does at each load: Runtime::removeSector of the sector the
// camera left, then Runtime::addSector of the decoded sector arriving (the slot's planes, its
// index grid's nearest probes, its LPRT sources resolved against the resident ones and relit
// under the 32 lights). The sector is {3, 0}, where the movers' circles reach. Arg: its
// sources (0: an unlit world's sector, 128: a lit one's; the resident sectors have as many).
// Every index-grid cell names a probe, as in the island's sectors (none of 249 loaded in its fly
// has an empty cell; an empty one costs a scan of the sector's probes). Second arg: the LPRT
// block borrowed (1, as the fly's sink does) or copied (0).
void BM_StreamSectorIn(benchmark::State& state) {
  const int sources = int(state.range(0));
  const SectorBlock keep = state.range(1) ? SectorBlock::kBorrow : SectorBlock::kCopy;
  Runtime rt;
  for (SectorKey k : residentKeys())
    if (!rt.addSector(testing::makeSector(k, {.probes = 70, .sources = sources, .no_probe_fraction = 0.f}, 1))) std::abort();
  (void)rt.setTime(12.0);
  Movers m;
  (void)rt.setLights(m.at(0));
  rt.update({0.0, 0.0, 12.0});
  const Sector arriving = testing::makeSector({3, 0}, {.probes = 70, .sources = sources, .no_probe_fraction = 0.f}, 1);
  for (auto _ : state) {
    if (!rt.removeSector({3, 0})) std::abort();
    if (!rt.addSector(arriving, nullptr, keep)) std::abort();
  }
}
BENCHMARK(BM_StreamSectorIn)->Args({0, 0})->Args({128, 0})->Args({128, 1})->Unit(benchmark::kMicrosecond);

// The worst case: one huge light spread on 64 source probes (the most sources_per_light allows,
// by the nearest rule), so that most sources of every probe carry energy and the LPRT block streams.
void BM_RelightWithLprtAllSourcesLit(benchmark::State& state) {
  ProbeCache cache = makeCache(128, 64, LightSources::kNearest);  // the most a light may be spread on
  const PointLight light{"everywhere", {0.0, 0.0, 12.0}, glm::vec3(1.f), 1e4f};
  const RelightInput in = noonInput(std::span(&light, 1));
  for (auto _ : state) {
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
}
BENCHMARK(BM_RelightWithLprtAllSourcesLit)->Unit(benchmark::kMicrosecond);

void BM_PackAllProbes(benchmark::State& state) {
  ProbeCache cache = makeCache(0);
  cache.relightAll(noonInput());
  const float scale = cache.maxColour() * 1.25f;
  for (auto _ : state) {
    cache.pack(scale);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
}
BENCHMARK(BM_PackAllProbes)->Unit(benchmark::kMicrosecond);

ProbeCache makePackedCache(Representation r = Representation::kFc3) {
  ProbeCache cache = makeCache(0, 4, LightSources::kVisibleFromLight, r);
  cache.relightAll(noonInput());
  cache.pack(cache.maxColour() * 1.25f);
  return cache;
}

void fullRefill(benchmark::State& state, VolumeOptions o) { testing::timeFullRefill(state, makePackedCache(o.representation), o); }
void BM_FullRefillNearest(benchmark::State& state) { fullRefill(state, {}); }
void BM_FullRefillSmooth(benchmark::State& state) { fullRefill(state, {.fill = FillMode::kSmooth}); }
void BM_FullRefillNearestBlurred(benchmark::State& state) { fullRefill(state, {.blur = true}); }
BENCHMARK(BM_FullRefillNearest)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FullRefillSmooth)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FullRefillNearestBlurred)->Unit(benchmark::kMicrosecond);
// sh-l1's fills beside fc3's above (issue 13: within 1.3x).
void BM_FullRefillNearestShL1(benchmark::State& state) { fullRefill(state, {.representation = Representation::kShL1}); }
void BM_FullRefillSmoothShL1(benchmark::State& state) {
  fullRefill(state, {.fill = FillMode::kSmooth, .representation = Representation::kShL1});
}
BENCHMARK(BM_FullRefillNearestShL1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_FullRefillSmoothShL1)->Unit(benchmark::kMicrosecond);

// One texel back and forth along an axis: each iteration computes one slab.
void scrollOne(benchmark::State& state, int axis, VolumeOptions o) {
  const ProbeCache cache = makePackedCache();
  Volume v(o);
  glm::ivec3 origin = v.originFor({10.0, -20.0, 12.0});
  v.rebuild(origin, cache);
  int step = 1;
  for (auto _ : state) {
    origin[axis] += step;
    step = -step;
    v.scrollTo(origin, cache);
    benchmark::ClobberMemory();
  }
}
void BM_ScrollOneTexelX(benchmark::State& state) { scrollOne(state, 0, {}); }
void BM_ScrollOneTexelY(benchmark::State& state) { scrollOne(state, 1, {}); }
void BM_ScrollOneTexelZ(benchmark::State& state) { scrollOne(state, 2, {}); }
void BM_ScrollOneTexelXSmooth(benchmark::State& state) { scrollOne(state, 0, {.fill = FillMode::kSmooth}); }
void BM_ScrollOneTexelXBlurred(benchmark::State& state) { scrollOne(state, 0, {.blur = true}); }
BENCHMARK(BM_ScrollOneTexelX)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelY)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelZ)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelXSmooth)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelXBlurred)->Unit(benchmark::kMicrosecond);
void BM_ScrollOneTexelYBlurred(benchmark::State& state) { scrollOne(state, 1, {.blur = true}); }
void BM_ScrollOneTexelZBlurred(benchmark::State& state) { scrollOne(state, 2, {.blur = true}); }
BENCHMARK(BM_ScrollOneTexelYBlurred)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelZBlurred)->Unit(benchmark::kMicrosecond);

// The z goal's trade (docs/runtime.md): a z slab is 1/(depth - 1) of the texels, so a one-texel z
// scroll reaches 1/50 of a refill only with >= 51 layers. The same texel size, 64 layers (4x
// the memory): the refill and the z scroll side by side.
constexpr VolumeOptions kDeep{.size = {96, 96, 64}};
void BM_FullRefillNearestDeep64(benchmark::State& state) { fullRefill(state, kDeep); }
void BM_ScrollOneTexelZDeep64(benchmark::State& state) { scrollOne(state, 2, kDeep); }
BENCHMARK(BM_FullRefillNearestDeep64)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScrollOneTexelZDeep64)->Unit(benchmark::kMicrosecond);

std::vector<std::pair<glm::dvec3, glm::vec3>> lookupPoints() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-80.0, 80.0), h(2.0, 25.0);
  std::normal_distribution<float> g;
  std::vector<std::pair<glm::dvec3, glm::vec3>> pts;
  for (int i = 0; i < 4096; ++i) pts.push_back({{u(rng), u(rng), h(rng)}, glm::normalize(glm::vec3(g(rng), g(rng), g(rng)))});
  return pts;
}

void BM_SampleVolume(benchmark::State& state) {
  const ProbeCache cache = makePackedCache();
  Volume v;
  v.rebuild(v.originFor({0.0, 0.0, 12.0}), cache);
  const auto pts = lookupPoints();
  size_t i = 0;
  for (auto _ : state) {
    const auto& [p, n] = pts[i++ & 4095];
    benchmark::DoNotOptimize(sampleVolume(v, p, n, 1.f));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_SampleVolume);

void BM_RuntimeAmbient(benchmark::State& state) {
  Runtime rt;
  for (SectorKey k : residentKeys())
    if (!rt.addSector(testing::makeSector(k, {.probes = 70}, 1))) std::abort();
  (void)rt.setTime(12.0);
  rt.update({0.0, 0.0, 12.0});
  const auto pts = lookupPoints();
  size_t i = 0;
  for (auto _ : state) {
    const auto& [p, n] = pts[i++ & 4095];
    benchmark::DoNotOptimize(rt.ambient(p, n));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RuntimeAmbient);

// What a frame costs when the time of day moved past the threshold: relight, pack, refill the
// back buffer and publish.
void relightFrames(benchmark::State& state, RuntimeOptions options) {
  Runtime rt(options);
  for (SectorKey k : residentKeys())
    if (!rt.addSector(testing::makeSector(k, {.probes = 70}, 1))) std::abort();
  double hour = 8.0;
  for (auto _ : state) {
    hour += 0.05;
    (void)rt.setTime(hour);
    rt.update({0.0, 0.0, 12.0});
  }
}
void BM_RuntimeRelightFrame(benchmark::State& state) { relightFrames(state, {}); }
BENCHMARK(BM_RuntimeRelightFrame)->Unit(benchmark::kMicrosecond);
// The same with the volume blur (the island's default): the refill's fill and blur spread over
// two frames (RuntimeOptions::volume_rebuild_updates, publish.h), and, for comparison, in one.
void BM_RuntimeRelightFrameBlurred(benchmark::State& state) {
  RuntimeOptions o;
  o.volume.blur = true;
  o.volume_rebuild_updates = int(state.range(0));
  relightFrames(state, o);
}
BENCHMARK(BM_RuntimeRelightFrameBlurred)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace drtv::runtime

BENCHMARK_MAIN();
