// drtv_limit_bench — the relight (fc3, and sh-l1 with its sun transfer) and the volume's full
// refill against the least work their formulas allow, on the same probes and the same lighting,
// one core, in one run (issue 38):
// so that every CPU the project meets is measured the same way, and the ratio, not a figure
// typed in, says how far the runtime is from the machine's limit.
//
// The limit kernel (fc3, no LPRT), written from the formula alone (representation.h, kFc3):
//   colour[c][b][i] = clamp(sum_k L[c][k] T[c][b][k][i] + D[c][b] v[b][i]),
// with L = sky + sun SH summed and D[c][b] = dot(cosineLobe(B_b), SkySH_direct[c]) computed once
// per frame (not per probe, nor per sector); the transfer in float, structure of arrays,
// coefficient-major over all 3,570 resident probes in one run (51 sectors of 70, no per-sector
// padding or bookkeeping); the largest clamped colour kept in the same pass; compiled for the
// same instruction sets as the runtime's kernels (DRTV_SIMD_CLONES) and auto-vectorised across
// probes. 4 x 3 x 5 multiply-adds, ~108 FLOP a probe with the clamp.
//
// The limit kernel of sh-l1 with its sun transfer (representation.h, kShL1, archive version 3,
// what new worlds bake), per channel c and coefficient i (q = 4 c + i):
//   e[q] = sum_j L[c][j] M[c][i][j] + d0[c] P0_i + d2[c] P2_i + a[q] S_k0[q] + b[q] S_k1[q],
// e0 clamped to [0, kMaxColour] and e1..3 to +-kMaxColour; L, d0, d2, the sun samples' weights
// and a, b once per frame; M, P0, P2 and the two sun samples read in float (the runtime keeps
// the sun transfer dequantised too). 12 x 8 multiply-adds a probe.
//
// The runtime's path is ProbeCache::relightAll on the same synthetic sectors
// (bench/common/runtime_world.h) that drtv_runtime_bench's BM_RelightWithoutLprt/0 relights. At
// exit the ratio runtime / limit is printed, of real time and of CPU time (the steadier of the two
// on a shared host; both paths run on the calling thread). The refill's limit kernel is described
// at BM_LimitRefill; the blurred refill is printed against the plain one (issue 38's goal: 1.5x).
// Run a Release build:
//   drtv_limit_bench --benchmark_min_time=0.5 --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "drtv/formats/sh.h"
#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/runtime.h"
#include "refill_loop.h"
#include "runtime_world.h"
#include "simd_clones.h"

namespace drtv::runtime {
namespace {

constexpr int kSectors = kMaxResidentSectors;  // 51
constexpr int kProbesPerSector = 70;
constexpr int kProbes = kSectors * kProbesPerSector;  // 3,570
constexpr int kN = (kProbes + 15) & ~15;              // one run of planes, padded once

// drtv_runtime_bench's 51 keys (its makeCache): the 7 x 7 block and two more.
std::vector<SectorKey> residentKeys() {
  std::vector<SectorKey> keys;
  for (int y = -3; y <= 3; ++y)
    for (int x = -3; x <= 3; ++x) keys.push_back({x, y});
  keys.push_back({4, 0});
  keys.push_back({-4, 0});
  return keys;
}

RelightInput noonInput() {
  const SkyLighting s = evaluateSky(Sky::tropicalDefault(), 12.0);
  RelightInput in{s.sky_sh, s.sun_sh, s.sky_direct_sh, {}, kAllComponents};
  in.sun_direction = s.sun_direction;
  in.sun_irradiance = s.sun_irradiance;
  return in;
}

// The limit kernel: 48 transfer planes [c][b][k] and 4 visibility planes [b] of kN floats in,
// 12 colour planes [c][b] out; returns the largest clamped colour.
DRTV_SIMD_CLONES float limitRelightFc3(const float* __restrict t, const float* __restrict v, float* __restrict out,
                                       const float (&l)[3][4], const float (&d)[3][4]) {
  int32_t m = 0;
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b) {
      const float* __restrict t0 = t + size_t((c * 4 + b) * 4) * kN;
      const float* __restrict t1 = t0 + kN;
      const float* __restrict t2 = t1 + kN;
      const float* __restrict t3 = t2 + kN;
      const float* __restrict vb = v + size_t(b) * kN;
      float* __restrict o = out + size_t(c * 4 + b) * kN;
      const float l0 = l[c][0], l1 = l[c][1], l2 = l[c][2], l3 = l[c][3], db = d[c][b];
      for (int i = 0; i < kN; ++i) {
        const float x = l0 * t0[i] + l1 * t1[i] + l2 * t2[i] + l3 * t3[i] + db * vb[i];
        const float y = x > 0.f ? x : 0.f;
        const float z = y < kMaxColour ? y : kMaxColour;
        o[i] = z;
        m = std::max(m, std::bit_cast<int32_t>(z));  // z >= 0: bit patterns order like the floats
      }
    }
  return std::bit_cast<float>(m);
}

void BM_LimitRelightFc3(benchmark::State& state) {
  std::vector<float> t(size_t(48) * kN, 0.f), v(size_t(4) * kN, 0.f), out(size_t(12) * kN);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.f, 0.3f);
  for (int p = 0; p < 48; ++p)
    for (int i = 0; i < kProbes; ++i) t[size_t(p) * kN + size_t(i)] = u(rng);
  for (int p = 0; p < 4; ++p)
    for (int i = 0; i < kProbes; ++i) v[size_t(p) * kN + size_t(i)] = 3.f * u(rng);
  const RelightInput in = noonInput();
  for (auto _ : state) {
    // Once per frame: the bounce lighting and each basis's direct-sky colour.
    float l[3][4], d[3][4];
    for (int c = 0; c < 3; ++c) {
      const sh::Sh4 bounce = in.sky_sh[c] + in.sun_sh[c];
      for (int k = 0; k < 4; ++k) l[c][k] = bounce[k];
      for (int b = 0; b < 4; ++b) d[c][b] = glm::dot(sh::cosineLobe(sh::kBasis[b]), in.sky_direct_sh[c]);
    }
    benchmark::DoNotOptimize(limitRelightFc3(t.data(), v.data(), out.data(), l, d));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kProbes);
}
BENCHMARK(BM_LimitRelightFc3)->Unit(benchmark::kMicrosecond);

void BM_RuntimeRelightFc3(benchmark::State& state) {
  ProbeCache cache({.max_sectors = kSectors, .representation = Representation::kFc3});
  for (SectorKey k : residentKeys())
    if (!cache.addSector(testing::makeSector(k, {.probes = kProbesPerSector, .sources = 0, .lprt_on_bases = true}, 1))) std::abort();
  const RelightInput in = noonInput();
  for (auto _ : state) {
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
  state.counters["probes"] = double(cache.probeCount());
}
BENCHMARK(BM_RuntimeRelightFc3)->Unit(benchmark::kMicrosecond);

DRTV_SIMD_CLONES float limitRelightShL1(const float* __restrict m, const float* __restrict p, const float* __restrict s0,
                                        const float* __restrict s1, float* __restrict out, const float (&l)[3][4],
                                        const float (&d0)[3], const float (&d2)[3], const float (&a)[12], const float (&b)[12]) {
  int32_t mx = 0;
  for (int q = 0; q < 12; ++q) {
    const int c = q / 4, i = q % 4;
    const float* __restrict m0 = m + size_t(q * 4) * kN;
    const float* __restrict m1 = m0 + kN;
    const float* __restrict m2 = m1 + kN;
    const float* __restrict m3 = m2 + kN;
    const float* __restrict p0 = p + size_t(i) * kN;
    const float* __restrict p2 = p + size_t(4 + i) * kN;
    const float* __restrict x = s0 + size_t(q) * kN;
    const float* __restrict y = s1 + size_t(q) * kN;
    float* __restrict o = out + size_t(q) * kN;
    const float l0 = l[c][0], l1 = l[c][1], l2 = l[c][2], l3 = l[c][3], e0 = d0[c], e2 = d2[c], aq = a[q], bq = b[q];
    const float lo = i == 0 ? 0.f : -kMaxColour;
    for (int k = 0; k < kN; ++k) {
      const float v = l0 * m0[k] + l1 * m1[k] + l2 * m2[k] + l3 * m3[k] + e0 * p0[k] + e2 * p2[k] + aq * x[k] + bq * y[k];
      const float w = v > lo ? v : lo;  // NaN -> lo here, 0 below
      const float z = v == v ? (w < kMaxColour ? w : kMaxColour) : 0.f;
      o[k] = z;
      mx = std::max(mx, std::bit_cast<int32_t>(z) & 0x7fffffff);
    }
  }
  return std::bit_cast<float>(mx);
}

void BM_LimitRelightShL1(benchmark::State& state) {
  std::vector<float> m(size_t(48) * kN, 0.f), p(size_t(8) * kN, 0.f), s0(size_t(12) * kN, 0.f), s1(size_t(12) * kN, 0.f),
      out(size_t(12) * kN);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.1f, 0.3f);
  for (std::vector<float>* v : {&m, &p, &s0, &s1})
    for (size_t j = 0; j < v->size(); ++j)
      if (int(j % size_t(kN)) < kProbes) (*v)[j] = u(rng);
  // The synthetic sectors' sun path (bench/common/runtime_world.h): 6 samples east, over the top, west.
  std::vector<glm::vec3> path;
  for (int k = 0; k < 6; ++k) {
    const float ang = 3.14159265f * float(k) / 5.f;
    path.push_back(glm::normalize(glm::vec3(std::cos(ang), -0.3f * std::sin(ang), std::sin(ang))));
  }
  const RelightInput in = noonInput();
  std::vector<float> w(path.size());
  for (auto _ : state) {
    // Once per frame: the bounce lighting, the direct sky's d0 and d2, the sun samples' weights.
    float l[3][4], d0[3], d2[3], a[12], b[12];
    for (int c = 0; c < 3; ++c) {
      const sh::Sh4 bounce = in.sky_sh[c] + in.sun_sh[c];
      for (int k = 0; k < 4; ++k) l[c][k] = bounce[k];
      d0[c] = in.sky_direct_sh[c][0];
      d2[c] = in.sky_direct_sh[c][2];
    }
    sunTransferWeights(path, in.sun_direction, w);
    size_t k0 = w.size(), k1 = w.size();
    for (size_t k = 0; k < w.size(); ++k)
      if (w[k] != 0.f) (k0 == w.size() ? k0 : k1) = k;
    if (k0 == w.size()) k0 = 0;
    if (k1 == w.size()) k1 = k0;
    for (int q = 0; q < 12; ++q) {
      const float e = in.sun_irradiance[q / 4] * (q % 4 == 0 ? sh::kCosineLobe0 : sh::kCosineLobe1);
      a[q] = w[k0] * e;
      b[q] = k1 == k0 ? 0.f : w[k1] * e;
    }
    benchmark::DoNotOptimize(limitRelightShL1(m.data(), p.data(), s0.data(), s1.data(), out.data(), l, d0, d2, a, b));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * kProbes);
}
BENCHMARK(BM_LimitRelightShL1)->Unit(benchmark::kMicrosecond);

void BM_RuntimeRelightShL1(benchmark::State& state) {
  ProbeCache cache({.max_sectors = kSectors, .representation = Representation::kShL1});
  for (SectorKey k : residentKeys())
    if (!cache.addSector(testing::makeSector(k, {.probes = kProbesPerSector, .sources = 0, .sky_fit = true, .sun_samples = 6}, 1)))
      std::abort();
  RelightInput in = noonInput();
  in.sun_transfer = true;
  for (auto _ : state) {
    cache.relightAll(in);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * cache.probeCount());
  state.counters["probes"] = double(cache.probeCount());
}
BENCHMARK(BM_RuntimeRelightShL1)->Unit(benchmark::kMicrosecond);

// The limit of a full refill of the talk's volume (3 textures of 96 x 96 x 16 RGBA8 texels,
// 2 x 2 x 4 m texels over 4 m index cells): each texel a copy of its probe's three words, packed
// once per probe (ProbeCache::pack), row by row. Per cell of a row, one index read and the probe's
// three words stored twice (the cell's two texels in x) with one 8-byte store per texture; the
// texel-to-probe index resolved beforehand (2 bytes a cell, 48 x 48 x 16 cells), the probes'
// words in one array (3,570 probes), no toroidal wrap, no sector lookups, no boundary copies.
// A cell's second row of texels (2 m rows in 4 m cells) is a copy of its first: the runtime's fill
// does that since 2026-12-08, and a limit that looked it up again was slower than the runtime.
constexpr int kFillX = 96, kFillY = 96, kFillZ = 16, kCellsX = kFillX / 2;
void limitFill(const uint16_t* __restrict cells, const uint32_t* __restrict packed, uint32_t* __restrict c0,
               uint32_t* __restrict c1, uint32_t* __restrict c2) {
  for (int z = 0; z < kFillZ; ++z)
    for (int y = 0; y < kFillY; ++y) {
      const uint16_t* __restrict row = cells + (size_t(z) * (kFillY / 2) + size_t(y / 2)) * kCellsX;
      const size_t base = (size_t(z) * kFillY + size_t(y)) * kFillX;
      if (y % 2 == 1) {
        std::memcpy(c0 + base, c0 + base - kFillX, kFillX * sizeof(uint32_t));
        std::memcpy(c1 + base, c1 + base - kFillX, kFillX * sizeof(uint32_t));
        std::memcpy(c2 + base, c2 + base - kFillX, kFillX * sizeof(uint32_t));
        continue;
      }
      for (int x = 0; x < kCellsX; ++x) {
        const uint32_t* p = packed + 3 * size_t(row[x]);
        const uint64_t w0 = p[0] * 0x100000001ull, w1 = p[1] * 0x100000001ull, w2 = p[2] * 0x100000001ull;
        std::memcpy(c0 + base + 2 * size_t(x), &w0, 8);
        std::memcpy(c1 + base + 2 * size_t(x), &w1, 8);
        std::memcpy(c2 + base + 2 * size_t(x), &w2, 8);
      }
    }
}

void BM_LimitRefill(benchmark::State& state) {
  std::vector<uint16_t> cells(size_t(kCellsX) * (kFillY / 2) * kFillZ);
  std::vector<uint32_t> packed(size_t(3) * kProbes);
  std::mt19937 rng(11);
  for (uint16_t& c : cells) c = uint16_t(rng() % uint32_t(kProbes));
  for (uint32_t& w : packed) w = rng();
  const size_t texels = size_t(kFillX) * kFillY * kFillZ;
  std::vector<uint32_t> c0(texels), c1(texels), c2(texels);
  for (auto _ : state) {
    limitFill(cells.data(), packed.data(), c0.data(), c1.data(), c2.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * int64_t(texels));
}
BENCHMARK(BM_LimitRefill)->Unit(benchmark::kMicrosecond);

// The runtime's full refill of the same volume (drtv_runtime_bench's BM_FullRefillNearest and
// its sh-l1 and blurred forms): the 51 synthetic sectors relit at noon and packed.
void runtimeRefill(benchmark::State& state, VolumeOptions o) {
  ProbeCache cache({.max_sectors = kSectors, .representation = o.representation});
  const bool sh_l1 = o.representation == Representation::kShL1;
  for (SectorKey k : residentKeys())
    if (!cache.addSector(testing::makeSector(k, {.probes = kProbesPerSector, .sources = 0, .lprt_on_bases = !sh_l1,
                                                 .sky_fit = sh_l1, .sun_samples = sh_l1 ? 6 : 0}, 1)))
      std::abort();
  RelightInput in = noonInput();
  in.sun_transfer = sh_l1;
  cache.relightAll(in);
  cache.pack(cache.maxColour() * 1.25f);
  testing::timeFullRefill(state, cache, o);
}
void BM_RuntimeRefillFc3(benchmark::State& state) { runtimeRefill(state, {}); }
void BM_RuntimeRefillShL1(benchmark::State& state) { runtimeRefill(state, {.representation = Representation::kShL1}); }
void BM_RuntimeRefillFc3Blurred(benchmark::State& state) { runtimeRefill(state, {.blur = true}); }
BENCHMARK(BM_RuntimeRefillFc3)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RuntimeRefillShL1)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RuntimeRefillFc3Blurred)->Unit(benchmark::kMicrosecond);

// Prints the runs as the console does and, at the end, each runtime path against its limit
// (the medians when repeated, else the last run of each).
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& r : runs) {
      const std::string name = r.benchmark_name();
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name != "median") continue;
      const std::string base = name.substr(0, name.find("_median"));
      if (r.run_type == Run::RT_Iteration && repeated_.count(base)) continue;
      if (r.run_type == Run::RT_Aggregate) repeated_[base] = true;
      time_[base] = {r.GetAdjustedRealTime(), r.GetAdjustedCPUTime()};
    }
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    auto ratio = [&](const char* what, const char* runtime_path, const char* limit) {
      if (!time_.count(runtime_path) || !time_.count(limit)) return;
      const auto [rt, rc] = time_[runtime_path];
      const auto [lt, lc] = time_[limit];
      const bool plain = std::string(limit).find("Limit") == std::string::npos;  // a runtime path beside another
      std::printf("%s: runtime %.2f us, %s %.2f us: %.2fx (CPU time: %.2fx)\n", what, rt, plain ? "plain" : "limit", lt, rt / lt,
                  rc / lc);
    };
    ratio("relight fc3, 3,570 probes, no LPRT", "BM_RuntimeRelightFc3", "BM_LimitRelightFc3");
    ratio("relight sh-l1 with its sun transfer, 3,570 probes, no LPRT", "BM_RuntimeRelightShL1", "BM_LimitRelightShL1");
    ratio("full refill fc3, 3 x 96x96x16", "BM_RuntimeRefillFc3", "BM_LimitRefill");
    ratio("full refill sh-l1, 3 x 96x96x16", "BM_RuntimeRefillShL1", "BM_LimitRefill");
    ratio("blurred full refill fc3 against a plain one", "BM_RuntimeRefillFc3Blurred", "BM_RuntimeRefillFc3");
  }

 private:
  std::map<std::string, std::pair<double, double>> time_;  // real, CPU
  std::map<std::string, bool> repeated_;
};

}  // namespace
}  // namespace drtv::runtime

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  drtv::runtime::RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
