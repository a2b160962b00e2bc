// probe_cache_lights.cpp — part of ProbeCache (probe_cache.h: the references [1-3] and the layout).
// The lights' shares among the sources (distributeLights).
#include "drtv/runtime/probe_cache.h"

#include <algorithm>

#include "probe_cache_impl.h"
#include "world_limits.h"

namespace drtv::runtime {

using namespace detail;

namespace {

// The radius of the patch over which a light's falloff is matched to its source's
// (footprintFactor): the index grid's 4 m cell, the patch of surface a receiver finds its probe
// for. Chosen among 0 (the peak under the light), 2, 4, 8 m and none on two scenes against the
// path tracer: a lamp 6 m over open ground (tests/reference/local_lights_test.cpp: summed error
// 119 % none, 39 % at 8 m, 43 % at 4 m, 72 % at 2 m) and the Cornell world, whose ceiling lights
// land on sources 1.5 m over its blocks (local_lights 38.7 % none, 21.0 % at 8 m, 15.8 % at 4 m,
// 14.8 % at 2 m; docs/runtime.md, "Local lights"). 4 m is within 4 points of the best on both.
constexpr double kLightFootprintM = kGridCellSizeM;
// A source's height over its surface is taken as at least this (a probe's clearance, placement.h).
constexpr double kMinSourceHeightM = 0.25;
// A light this near a baked light's own source (kProbeLightSource) is that light: the bake put the
// source at its position (float metres in the sector's frame, so within ~1e-5 m of it); a moving
// light passing that close is as well lit from there.
constexpr double kLightSourceMatchM = 0.25;

// The mean irradiance of a unit point light (1 per sr) at height z over the disk of radius
// kLightFootprintM under it: the flux 2 pi (1 - z / sqrt(z^2 + r^2)) through the disk over its area.
double meanDiskIrradiance(double z) {
  constexpr double r2 = kLightFootprintM * kLightFootprintM;
  return 2.0 * (1.0 - z / std::sqrt(z * z + r2)) / r2;
}

}  // namespace

void ProbeCache::Impl::litSourcesOfAll(const RelightInput& li, std::vector<std::vector<LitSource>>& lit) const {
  lit.resize(slots.size());
  for (std::vector<LitSource>& l : lit) l.clear();
  if (!(li.components & kComponentLocalLights)) return;
  for (int id : touched) {
    if (!is_lit[size_t(id)]) continue;
    for (uint32_t who : namers[size_t(id)]) lit[who >> 16].push_back({size_t(who & 0xffffu), light_colour[size_t(id)]});
  }
  for (std::vector<LitSource>& l : lit)
    if (l.size() > 1) std::sort(l.begin(), l.end(), [](const LitSource& a, const LitSource& b) { return a.j < b.j; });
}

double ProbeCache::Impl::footprintFactor(double light_z, const ProbeRef& p) const {
  const Slot& sl = slots[p.slot];
  const double h = std::max(kMinSourceHeightM, double(sl.height[p.index]));
  const double H = light_z - (double(sl.position[p.index].z) - double(sl.height[p.index]));
  if (!(H > h)) return 1.0;
  return meanDiskIrradiance(H) / meanDiskIrradiance(h);
}

void ProbeCache::Impl::litSources(int s, const RelightInput& li, std::vector<LitSource>& lit) const {
  lit.clear();
  if (!(li.components & kComponentLocalLights)) return;
  for (int id : touched) {
    if (!is_lit[size_t(id)]) continue;
    for (uint32_t who : namers[size_t(id)])
      if (int(who >> 16) == s) lit.push_back({size_t(who & 0xffffu), light_colour[size_t(id)]});
  }
  if (lit.size() > 1) std::sort(lit.begin(), lit.end(), [](const LitSource& a, const LitSource& b) { return a.j < b.j; });
}

std::vector<LightShare> ProbeCache::Impl::distribute(std::span<const PointLight> lights) const {
  std::vector<LightShare> shares;
  const int k_max = opt.sources_per_light;
  struct Candidate {
    double d2;
    ProbeRef p;
  };
  std::vector<Candidate> best;
  // Keeps the k_max nearest, sorted; ties keep the earlier (slot, index): deterministic.
  auto consider = [&](const ProbeRef& p, double d2) {
    for (const Candidate& c : best)
      if (c.p == p) return;
    if (int(best.size()) == k_max && d2 >= best.back().d2) return;
    if (int(best.size()) == k_max) best.pop_back();
    auto at = std::upper_bound(best.begin(), best.end(), d2, [](double v, const Candidate& c) { return v < c.d2; });
    best.insert(at, Candidate{d2, p});
  };
  auto world = [&](int s, int i) {
    const Slot& sl = slots[s];
    return glm::dvec3(sl.origin.x + sl.position[i].x, sl.origin.y + sl.position[i].y, sl.position[i].z);
  };
  // The baked light's own source where one stands at `at` and a resident sector names it.
  auto ownSource = [&](const glm::dvec3& at) -> ProbeRef {
    if (!(std::fabs(at.x) < kMaxWorldM && std::fabs(at.y) < kMaxWorldM && std::isfinite(at.z))) return {};
    const int s = slotOf(sectorAt(at.x, at.y));
    if (s < 0) return {};
    for (const uint8_t i : slots[s].light_sources) {
      const glm::dvec3 d = world(s, i) - at;
      if (glm::dot(d, d) <= kLightSourceMatchM * kLightSourceMatchM && !namers[size_t(s * kSlotProbes + i)].empty()) return {s, int(i)};
    }
    return {};
  };
  for (const PointLight& light : lights) {
    const double r = light.radius_m, r2 = r * r;
    best.clear();
    if (opt.own_light_sources) {
      if (const ProbeRef own = ownSource(light.position); own.valid()) {
        shares.push_back({own, light.intensity});
        continue;
      }
    }
    if (opt.light_sources == LightSources::kVisibleFromLight) {
      // The probes the index grid names in the 4 cells at the light's height whose centres
      // surround it (a bilinear look-up's cells). The bake named, for each cell, a probe that
      // sees it, so a probe on the far side of a roof or wall is not among them unless a cell
      // centre lies there too. Not the cells above: 4 m x 4 m x ~1.5 m cells put a centre above
      // a roof as soon as a lamp hangs within a cell of it. Such a cell names the probe standing
      // on the roof, whose floor (height_m below it) is above the light: that probe cannot see
      // the light, so the column is walked down, a cell at a time, to the first named source that
      // does not stand on a surface above the light (a ceiling quad 1 cm under the Cornell box's
      // roof sent all its light to the roof's top before: docs/runtime.md, "Local lights").
      auto lower = [](double v) { return (std::floor(v / kGridCellSizeM - 0.5) + 0.5) * kGridCellSizeM; };
      for (int k = 0; k < 4; ++k) {
        glm::dvec3 at = light.position;
        // The lower corner of the surrounding centres, then this corner's offset.
        at.x = lower(at.x) + ((k & 1) ? kGridCellSizeM : 0.0);
        at.y = lower(at.y) + ((k & 2) ? kGridCellSizeM : 0.0);
        if (!(std::fabs(at.x) < kMaxWorldM && std::fabs(at.y) < kMaxWorldM && std::isfinite(at.z))) continue;
        const int s = slotOf(sectorAt(at.x, at.y));
        if (s < 0 || slots[s].count == 0) continue;
        const Slot& sl = slots[s];
        for (int step = 0; step < kGridDim; ++step, at.z -= sl.cell_h) {
          const int i = namedProbe(s, at);
          if (i >= sl.count) break;
          const double floor_z = double(sl.position[i].z) - double(sl.height[i]);
          if (floor_z > light.position.z) {
            if (at.z < double(sl.z_min)) break;  // clamped into the bottom cell: nothing lower
            continue;
          }
          if (namers[size_t(s * kSlotProbes + i)].empty()) break;
          const glm::dvec3 d = world(s, i) - light.position;
          if (glm::dot(d, d) < r2) consider({s, i}, glm::dot(d, d));
          break;
        }
      }
    } else {
      for (size_t s = 0; s < slots.size(); ++s) {
        const Slot& sl = slots[s];
        if (!sl.used || sl.count == 0) continue;
        // Skip sectors whose probes' bounding box is out of reach.
        const glm::dvec3 lo(sl.origin.x + sl.lo.x, sl.origin.y + sl.lo.y, sl.lo.z);
        const glm::dvec3 hi(sl.origin.x + sl.hi.x, sl.origin.y + sl.hi.y, sl.hi.z);
        const glm::dvec3 gap = glm::max(glm::dvec3(0.0), glm::max(lo - light.position, light.position - hi));
        if (glm::dot(gap, gap) >= r2) continue;
        for (int i = 0; i < sl.count; ++i) {
          if (namers[s * kSlotProbes + size_t(i)].empty() || (sl.flags[size_t(i)] & kProbeLightSource)) continue;
          const glm::dvec3 d = world(int(s), i) - light.position;
          const double d2 = glm::dot(d, d);
          if (d2 < r2) consider({int(s), i}, d2);
        }
      }
    }
    double sum = 0.0;
    std::array<double, 64> w{};
    for (size_t i = 0; i < best.size() && i < w.size(); ++i) {
      const double t = 1.0 - best[i].d2 / r2;
      w[i] = t * t;
      sum += w[i];
    }
    if (!(sum > 0.0)) continue;
    for (size_t i = 0; i < best.size() && i < w.size(); ++i)
      shares.push_back({best[i].p, light.intensity * float(w[i] / sum * footprintFactor(light.position.z, best[i].p))});
  }
  return shares;
}

int ProbeCache::sourcesNaming(ProbeRef p) const {
  DRTV_CHECK(slotUsed(p.slot) && p.index >= 0 && p.index < impl_->slots[size_t(p.slot)].count);
  return int(impl_->namers[size_t(p.slot) * kSlotProbes + size_t(p.index)].size());
}

std::vector<LightShare> ProbeCache::distributeLights(std::span<const PointLight> lights) const {
  return impl_->distribute(lights);
}

void ProbeCache::Impl::setLights(std::span<const PointLight> lights) {
  for (int id : touched) light_colour[id] = glm::vec3(0.f), is_lit[id] = 0;
  touched.clear();
  // is_lit marks the ids in `touched` while the shares are summed: once each, also where a share
  // is 0 (a light of intensity 0) and another light's share follows (a zero colour as the test
  // pushed such an id twice, and litSourcesOfAll would have counted its sources twice).
  for (const LightShare& sh : distribute(lights)) {
    const int id = sh.probe.slot * kSlotProbes + sh.probe.index;
    if (!is_lit[id]) is_lit[id] = 1, touched.push_back(id);
    light_colour[id] += sh.colour;
  }
  for (int id : touched) is_lit[id] = light_colour[id] != glm::vec3(0.f);
}

}  // namespace drtv::runtime
