// Deterministic synthetic sectors and slow, obvious references for the runtime tests.
#pragma once

#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "drtv/formats/sector.h"
#include "drtv/formats/sh.h"
#include "drtv/runtime/probe_cache.h"

namespace drtv::testing {

// Smooth terrain height (world metres) shared by every synthetic sector, so that neighbouring
// sectors join up.
inline float terrainZ(double x, double y) { return float(10.0 + 6.0 * std::sin(x / 37.0) * std::cos(y / 53.0)); }

struct SectorSpec {
  int probes = 70;
  int sources = 0;          // LPRT sources (0 = none)
  bool lprt_on_bases = true;
  float no_probe_fraction = 0.1f;  // index-grid cells left at 255
  bool uniform = false;     // every probe identical (a uniform volume)
  bool sky_moments = false; // an sh-l1 bake's records of version 2 (kProbeSkyMoments, representation.h)
  bool sky_fit = false;     // an sh-l1 bake's records of version 3 (kProbeSkyFit)
  int sun_samples = 0;      // a sun transfer of that many samples along a noon-high path (sector.h SunBlock)
};

// A sector with `spec.probes` probes on a jittered 8 m lattice 1.5 m above the terrain, an index
// grid naming the truly nearest probe (some cells 255), a ground map and optional LPRT whose
// sources are probes of this sector and its eight neighbours (all built with the same spec).
inline Sector makeSector(SectorKey key, const SectorSpec& spec, uint32_t seed) {
  std::mt19937 rng(seed * 7919u + uint32_t(key.ix * 131 + key.iy * 17 + 1000));
  std::uniform_real_distribution<float> u(0.f, 1.f);
  Sector s;
  s.key = key;
  const double ox = key.ix * kSectorSizeM, oy = key.iy * kSectorSizeM;
  for (int i = 0; i < spec.probes; ++i) {
    ProbeData p;
    const int gx = i % 8, gy = (i / 8) % 8;
    const float x = spec.uniform ? 32.f : std::min(63.9f, gx * 8.f + 1.f + 6.f * u(rng));
    const float y = spec.uniform ? 32.f : std::min(63.9f, gy * 8.f + 1.f + 6.f * u(rng));
    p.position = {x, y, terrainZ(ox + x, oy + y) + 1.5f + (i / 64) * 4.f};
    for (int c = 0; c < 3; ++c)
      for (int b = 0; b < 4; ++b)
        for (int k = 0; k < 4; ++k)
          p.prt[c][b][k] = spec.uniform ? 0.1f * (k == 0) + 0.02f * (c + b) : (k == 0 ? 0.3f * u(rng) : 0.2f * (u(rng) - 0.5f));
    for (int b = 0; b < 3; ++b) p.sky_vis[b] = spec.uniform ? 0.7f : u(rng);
    p.sky_vis[3] = 0.f;
    p.height_m = 1.5f;
    p.mean_hit_m = 10.f;
    if (spec.sky_fit) {
      p.flags |= kProbeSkyFit;
      p.sky_fit_h = {1.5f * u(rng), 0.2f * (u(rng) - 0.5f), 1.2f * u(rng), 0.2f * (u(rng) - 0.5f)};
      p.sky_fit_delta = {0.8f * u(rng), 0.1f * (u(rng) - 0.5f), 0.9f * u(rng), 0.1f * (u(rng) - 0.5f)};
    }
    if (spec.sky_moments) {
      p.flags |= kProbeSkyMoments;
      p.sky_moments = spec.uniform ? glm::vec3(0.f, 0.3f, 0.f) : glm::vec3(0.1f * (u(rng) - 0.5f), 0.3f * u(rng), 0.1f * (u(rng) - 0.5f));
    }
    s.probes.push_back(packProbe(p));
  }
  s.grid.z_min_m = 0.f;
  s.grid.cell_height_m = 2.f;
  for (int z = 0; z < kGridDim; ++z)
    for (int y = 0; y < kGridDim; ++y)
      for (int x = 0; x < kGridDim; ++x) {
        uint8_t best = kNoProbe;
        float best_d2 = 1e30f;
        const float cx = (x + 0.5f) * 4.f, cy = (y + 0.5f) * 4.f, cz = (z + 0.5f) * 2.f;
        for (int i = 0; i < spec.probes; ++i) {
          const float dx = s.probes[i].position[0] - cx, dy = s.probes[i].position[1] - cy, dz = s.probes[i].position[2] - cz;
          const float d2 = dx * dx + dy * dy + dz * dz;
          if (d2 < best_d2) best_d2 = d2, best = uint8_t(i);
        }
        if (u(rng) < spec.no_probe_fraction) best = kNoProbe;
        s.grid.cells[IndexGrid::cellIndex(x, y, z)] = best;
      }
  s.has_ground = true;
  s.ground_z_min_m = 0.f;
  s.ground_z_max_m = 20.f;
  for (int y = 0; y < kGroundDim; ++y)
    for (int x = 0; x < kGroundDim; ++x)
      s.ground[y * kGroundDim + x] = quantizeUnorm16(terrainZ(ox + (x + 0.5) * 8, oy + (y + 0.5) * 8) / 20.f);
  if (spec.sun_samples > 0 && spec.probes > 0) {
    auto sun = std::make_unique<SunBlock>();
    for (int k = 0; k < spec.sun_samples; ++k) {
      const float a = 3.14159265f * float(k) / float(spec.sun_samples - 1);  // east, over the top, to west
      sun->directions.push_back(glm::normalize(glm::vec3(std::cos(a), -0.3f * std::sin(a), std::sin(a))));
    }
    for (int i = 0; i < spec.probes; ++i) sun->ranges.push_back(0.02f + 0.05f * u(rng));
    for (int q = 0; q < spec.probes * spec.sun_samples * 12; ++q) sun->coeffs.push_back(int8_t(int(rng() % 255) - 127));
    s.sun = std::move(sun);
  }
  if (spec.sources > 0 && spec.probes > 0) {
    for (int j = 0; j < spec.sources; ++j)
      s.lprt.sources.push_back({int8_t(j % 3 - 1), int8_t((j / 3) % 3 - 1), uint8_t((j * 7) % spec.probes)});
    s.lprt_on_bases = spec.lprt_on_bases;
    for (auto& r : s.probes) r.lprt_range = 0.05f + 0.1f * u(rng);
    s.lprt.coeffs.resize(size_t(spec.probes) * spec.sources * 12);
    for (auto& c : s.lprt.coeffs) c = int16_t(int(rng() % 40000) - 8000);
  }
  return s;
}

// The relighting formula of DESIGN.md, probe by probe, in double, from the record itself.
// `light_at` maps (sector key, probe index) of a source to the light colour assigned to it.
inline runtime::BasisColours referenceRelight(const Sector& sector, int probe, const sh::Sh4Rgb& sky, const sh::Sh4Rgb& sun,
                                              const sh::Sh4Rgb& sky_direct,
                                              const std::map<std::pair<SectorKey, int>, glm::dvec3>& light_at,
                                              uint32_t components = runtime::kAllComponents) {
  const ProbeData p = unpackProbe(sector.probes[probe]);
  runtime::BasisColours out;
  for (int b = 0; b < 4; ++b)
    for (int c = 0; c < 3; ++c) {
      double v = 0.0;
      for (int k = 0; k < 4; ++k) {
        if (components & runtime::kComponentSkyBounce) v += double(sky[c][k]) * p.prt[c][b][k];
        if (components & runtime::kComponentSunBounce) v += double(sun[c][k]) * p.prt[c][b][k];
        if (components & runtime::kComponentDirectSky) v += double(sh::cosineLobe(sh::kBasis[b])[k]) * sky_direct[c][k] * p.sky_vis[b];
      }
      if ((components & runtime::kComponentLocalLights) && sector.hasLprt()) {
        const double range = sector.probes[probe].lprt_range;
        for (size_t j = 0; j < sector.lprt.sources.size(); ++j) {
          const LprtSource& src = sector.lprt.sources[j];
          auto it = light_at.find({SectorKey{sector.key.ix + src.dx, sector.key.iy + src.dy}, int(src.probe)});
          if (it == light_at.end()) continue;
          double e = 0.0;
          if (sector.lprt_on_bases) {
            e = dequantizeSnorm16(sector.lprt.coeffs[sector.lprt.index(probe, j, c, b)], float(range));
          } else {
            for (int k = 0; k < 4; ++k)
              e += double(sh::cosineLobe(sh::kBasis[b])[k]) * dequantizeSnorm16(sector.lprt.coeffs[sector.lprt.index(probe, j, c, k)], float(range));
          }
          v += it->second[c] * e;
        }
      }
      out[b][c] = float(std::max(0.0, v));  // clamped once, at the end
    }
  return out;
}

}  // namespace drtv::testing
