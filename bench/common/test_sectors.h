// Deterministic sectors for the formats tests.
#pragma once

#include <memory>
#include <random>

#include "drtv/formats/sector.h"

namespace drtv::testing {

// A sector with `probes` probes, `sources` LPRT sources (0 = none) and a ground map, filled with
// values drawn from `seed`.
inline Sector makeSector(SectorKey key, int probes, int sources, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  Sector s;
  s.key = key;
  s.probes.reserve(probes);
  for (int i = 0; i < probes; ++i) {
    ProbeData p;
    p.position = {64.f * u(rng), 64.f * u(rng), 10.f + 30.f * u(rng)};
    for (auto& c : p.prt)
      for (auto& b : c)
        for (int k = 0; k < 4; ++k) b[k] = u(rng) - 0.3f;
    for (int b = 0; b < 4; ++b) p.sky_vis[b] = b == 3 ? 0.f : u(rng);
    p.sky_vis_sh = {u(rng) * 3.f, u(rng) - 0.5f, u(rng), u(rng) - 0.5f};
    p.height_m = 2.f * u(rng);
    p.mean_hit_m = 30.f * u(rng);
    s.probes.push_back(packProbe(p));
  }
  s.grid.z_min_m = 5.f;
  s.grid.cell_height_m = 3.f;
  for (int i = 0; i < kGridCells; ++i) s.grid.cells[i] = probes ? uint8_t(rng() % probes) : kNoProbe;
  s.has_ground = true;
  s.ground_z_min_m = 8.f;
  s.ground_z_max_m = 20.f;
  for (auto& g : s.ground) g = uint16_t(rng());
  if (sources > 0) {
    for (int j = 0; j < sources; ++j) s.lprt.sources.push_back({int8_t(j % 3 - 1), int8_t(j % 5 - 2), uint8_t(j % 200)});
    for (auto& r : s.probes) r.lprt_range = 0.5f + u(rng);
    s.lprt.coeffs.resize(size_t(probes) * sources * 12);
    for (auto& c : s.lprt.coeffs) c = int16_t(int(rng() % 65535) - 32767);
  }
  return s;
}

// A small, fully specified sector whose encoding the golden test pins.
inline Sector makeGoldenSector() {
  Sector s;
  s.key = {3, -1};
  for (int i = 0; i < 2; ++i) {
    ProbeData p;
    p.position = {8.f + 16.f * i, 40.f, 12.5f};
    p.flags = i ? kProbeVegetation : 0;
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 4; ++b)
        for (int k = 0; k < 4; ++k) p.prt[c][b][k] = 0.01f * (c * 16 + b * 4 + k) - 0.2f;
    p.sky_vis = {0.75f, 0.5f, 0.25f, 0.f};
    p.sky_vis_sh = {2.f, 0.25f, 1.f, -0.25f};
    p.height_m = 1.5f;
    p.mean_hit_m = 20.f;
    s.probes.push_back(packProbe(p));
  }
  s.grid.z_min_m = 50.f;
  s.grid.cell_height_m = 1.f;
  for (int i = 0; i < kGridCells; ++i) s.grid.cells[i] = uint8_t(i % 3 == 2 ? kNoProbe : i % 3);
  s.has_ground = true;
  s.ground_z_min_m = 48.f;
  s.ground_z_max_m = 64.f;
  for (int i = 0; i < kGroundDim * kGroundDim; ++i) s.ground[i] = uint16_t(i * 1000);
  s.lprt.sources = {{0, 0, 0}, {1, -1, 7}};
  s.probes[0].lprt_range = 0.5f;
  s.probes[1].lprt_range = 2.f;
  s.lprt.coeffs.resize(2 * 2 * 12);
  for (size_t i = 0; i < s.lprt.coeffs.size(); ++i) s.lprt.coeffs[i] = int16_t(i * 1300 - 20000);
  return s;
}

// Flags every `every`-th probe of `s` kProbeCovered and gives those visibility maps of
// pseudo-random bytes (any two bytes are a texel, visibility.h).
inline void coverProbes(Sector& s, int every, uint32_t seed) {
  size_t covered = 0;
  for (size_t i = 0; i < s.probes.size(); i += size_t(every)) {
    s.probes[i].flags |= kProbeCovered;
    ++covered;
  }
  if (covered == 0) return;
  auto vis = std::make_unique<VisibilityBlock>();
  vis->values.resize(covered * kVisBytesPerProbe);
  uint32_t x = seed * 2654435761u + 1u;
  for (uint8_t& b : vis->values) {
    x = x * 1664525u + 1013904223u;
    b = uint8_t(x >> 24);
  }
  s.visibility = std::move(vis);
}

inline constexpr uint64_t kGoldenSectorHash = 0xade51ce8991b1dc6ull;

}  // namespace drtv::testing
