// Probe placement (see placement.h for the rule and its references).
#include "drtv/baker/placement.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "drtv/raytrace/sampling.h"
#include "drtv/formats/probe.h"
#include "drtv/formats/sector.h"
#include "static_rays.h"

namespace drtv::baker {
namespace {

// Hits along one vertical ray, at most this many (a column through a 60-floor tower).
constexpr int kMaxHitsPerColumn = 128;
// Start vertical rays this far above the highest geometry.
constexpr float kRayTopMarginM = 10.f;
// Relocation offsets tried in order (metres): up first (most inside cases are a probe lifted
// into a slab or a terrain hit under a rock), then sideways.
constexpr glm::vec3 kRelocationOffsets[] = {{0, 0, 0.5f}, {0, 0, 1.f}, {0, 0, 2.f}, {0, 0, 4.f},
                                            {1, 0, 0},    {-1, 0, 0},  {0, 1, 0},   {0, -1, 0},
                                            {2, 0, 0},    {-2, 0, 0},  {0, 2, 0},   {0, -2, 0}};

enum Priority : int { kDesignated = 0, kCovered = 1, kTop = 2, kVegetation = 3 };

struct Candidate {
  glm::vec3 position;
  int priority;
  uint32_t order;
  uint16_t flags = 0;
  uint16_t interior = 0;
  bool enclosed_only = false;  // from the enclosed lattice: kept only if enclosed (step 4)
  bool enclosed = false;       // covered, and enclosed (placement.h kEnclosedWalls)
  float ceiling = INFINITY;    // a covered column hit's static surface above (step 4 stays under it)
};

using detail::isStatic;
using detail::nextRayStart;

// How far behind a candidate the inside test's rays start (surroundings): a surface within this of
// the point, or through it, is at distance ~0.
constexpr float kOnSurfaceM = 1e-3f;

// What the inside test's rays found around a point (step 4 of placement.h).
struct Surroundings {
  bool inside = false;         // many of its hits are back faces: inside geometry
  float nearest_static = INFINITY;  // the nearest static or terrain hit, metres
  bool clear(double clearance_m) const { return !inside && nearest_static >= float(clearance_m); }
};

Surroundings surroundings(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, const glm::vec3& p,
                          const PlacementSettings& s, uint64_t key, PlacementStats& stats) {
  const int n = s.inside_test_rays;
  std::vector<raytrace::Ray> rays(static_cast<size_t>(n));
  std::vector<raytrace::Hit> hits(static_cast<size_t>(n));
  const glm::vec2 shift(raytrace::unitFloat(raytrace::hashKey(key, 1)), raytrace::unitFloat(raytrace::hashKey(key, 2)));
  // Each ray starts kOnSurfaceM behind the point and its hits count from the point: a candidate
  // lying on a surface (a lattice column on a wall's plane: walls modelled on whole metres meet
  // the 2 m lattice) is at distance ~0 from it, where rays starting on the plane find no hit.
  // Without a clearance (the talk's placement) a probe may touch a surface, and its rays start at it.
  const float behind = s.clearance_m > 0.0 ? kOnSurfaceM : 0.f;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 d = raytrace::uniformSphere(raytrace::r2Point(uint32_t(i), shift));
    rays[i] = raytrace::Ray{p - behind * d, 0.f, d, float(s.inside_test_range_m) + behind};
  }
  scene.intersect(rays, hits);
  stats.rays += uint64_t(n);
  Surroundings out;
  int hit = 0, back = 0;
  for (int i = 0; i < n; ++i) {
    if (!hits[i].hit()) continue;
    ++hit;
    back += !scene.frontFace(rays[i], hits[i].prim);
    if (isStatic(geometry.cls[hits[i].prim])) out.nearest_static = std::min(out.nearest_static, std::max(0.f, hits[i].t - behind));
  }
  // Double-sided triangles have no back face, so this cannot see the inside of a closed
  // double-sided mesh. Counting their hits from behind the winding where every ray closes the
  // probe in (as the accuracy's buried test does) was measured on the Cornell world, whose blocks
  // are double-sided: it drops the probe under the short block, and the points around the block
  // then read a probe outside the box's open side (total error 15.7 -> 23.9 % on the same points).
  out.inside = hit > 0 && double(back) > kInsideBackfaceFraction * double(hit);
  return out;
}

// Whether walls close `p` in (placement.h kEnclosedWalls): horizontal rays within kEnclosedRangeM.
bool enclosed(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, const glm::vec3& p, PlacementStats& stats) {
  int walls = 0;
  for (int i = 0; i < kEnclosedRays; ++i) {
    const double a = 2.0 * 3.14159265358979323846 * (i + 0.5) / kEnclosedRays;
    const glm::vec3 d(float(std::cos(a)), float(std::sin(a)), 0.f);
    walls += std::isfinite(detail::staticHitDistance(scene, geometry, p, d, float(kEnclosedRangeM), kMaxHitsPerColumn, stats.rays));
  }
  return walls >= kEnclosedWalls;
}

// The least horizontal distances of step 5: an open candidate's, a covered one's (at most the
// open one) and an enclosed one's (at most the covered one).
struct LeastDistances {
  double open, covered, enclosed;
  double of(const Candidate& c) const { return c.priority != kCovered ? open : c.enclosed ? enclosed : covered; }
};

// Step 5 at the distances `now` (step 6 grows them from `base`). `hidden(c, a)`: whether static
// geometry stands between two probes of which one is covered (PlacementSettings::covered_sight;
// always false without it); such a pair rejects no one within the candidate's `base` distance,
// so that thinning (distances past `base`) still thins a block of rooms one probe a room.
template <class Hidden>
std::vector<Candidate> greedy(const std::vector<Candidate>& sorted, const LeastDistances& now, const LeastDistances& base, double min_v,
                              const Hidden& hidden) {
  std::vector<Candidate> accepted;
  for (const Candidate& c : sorted) {
    bool ok = true;
    const double reject_h = now.of(c), reject_h2 = reject_h * reject_h, base_h = base.of(c), base_h2 = base_h * base_h;
    if (c.priority != kDesignated)
      for (const Candidate& a : accepted) {
        const double dx = c.position.x - a.position.x, dy = c.position.y - a.position.y, dz = c.position.z - a.position.z;
        const double h2 = dx * dx + dy * dy;
        if (h2 < reject_h2 && std::abs(dz) < min_v &&
            !(h2 < base_h2 && (c.priority == kCovered || a.priority == kCovered || a.priority == kDesignated) && hidden(c, a))) {
          ok = false;
          break;
        }
      }
    if (ok) accepted.push_back(c);
  }
  return accepted;
}

}  // namespace

std::vector<PlacedProbe> placeProbes(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, glm::ivec2 offset,
                                     std::span<const LocalInterior> interiors, const PlacementSettings& s,
                                     PlacementStats& stats, std::span<const glm::vec3> light_sources) {
  DRTV_CHECK_LE(light_sources.size(), size_t(kMaxLightSourcesPerSector));
  const glm::vec2 base(float(offset.x * kSectorSizeM), float(offset.y * kSectorSizeM));
  const int32_t key_x = geometry.key.ix + offset.x, key_y = geometry.key.iy + offset.y;
  const uint64_t sector_key = raytrace::hashKey(s.seed, uint64_t(uint32_t(key_x)), uint64_t(uint32_t(key_y)), 0x706c6163ull);
  const float top = geometry.z_max + kRayTopMarginM;
  const float ray_len = geometry.z_max - geometry.z_min + 2.f * kRayTopMarginM;
  std::vector<Candidate> cands;
  uint32_t order = 0;

  // 1. Static pass.
  // covered_only: a column of the finer lattice under roofs, whose other hits are the coarse
  // lattice's to give.
  auto column = [&](float x, float y, bool covered_only, bool enclosed_only = false) {
      const glm::vec3 origin(x, y, top);
      float t = 0.f, z_above = INFINITY;
      for (int k = 0; k < kMaxHitsPerColumn; ++k) {
        const raytrace::Ray down{origin, t, glm::vec3(0, 0, -1), ray_len};
        const raytrace::Hit h = scene.intersect(down);
        ++stats.rays;
        if (!h.hit()) break;
        t = nextRayStart(h.t);
        if (!isStatic(geometry.cls[h.prim])) continue;
        const float z = origin.z - h.t;
        if (scene.facingNormal(down, h.prim).z > 0.f) {  // front face of a downward ray (either side if double-sided)
          // A double-sided triangle hit from behind under another surface is most likely the
          // underside of a closed double-sided mesh seen from inside it (a floor slab's bottom):
          // no candidate, or the slab's inside outranks the floor's top as a covered hit. With
          // nothing above (a ground authored upside down) it is a surface.
          const bool from_behind = scene.normal(h.prim).z < 0.f;
          if (from_behind && !std::isinf(z_above)) {
            z_above = z;
            continue;
          }
          if (covered_only && std::isinf(z_above)) {
            z_above = z;
            continue;
          }
          ++stats.static_candidates;
          if (z_above - z < float(2.0 * s.clearance_m)) {
            ++stats.dropped_gap;  // a slit: a probe there sees nothing but the two surfaces
          } else {
            const float lift = std::min(float(s.lift_m), 0.5f * (z_above - z));
            cands.push_back({glm::vec3(origin.x, origin.y, z + lift), std::isinf(z_above) ? kTop : kCovered, order++, 0, 0, enclosed_only,
                             false, z_above});
            // A space taller than a storey under its ceiling: more candidates up to lift_m / 2
            // under it (PlacementSettings::covered_stack_m).
            if (!std::isinf(z_above) && s.covered_stack_m > 0.0) {
              const double stack = std::max(s.covered_stack_m, s.min_vertical_m + kStackMarginM);
              const double top = double(z_above) - 0.5 * s.lift_m;
              for (int k = 1; k < kMaxHitsPerColumn && double(z) + lift + k * stack <= top; ++k)
                cands.push_back({glm::vec3(origin.x, origin.y, float(double(z) + lift + k * stack)), kCovered, order++, kProbeStacked, 0,
                                 enclosed_only, false, z_above});
            }
          }
        }
        z_above = z;
      }
  };
  const int columns = std::max(1, int(std::lround(kSectorSizeM / s.column_spacing_m)));
  const float step = float(kSectorSizeM / columns);
  for (int cy = 0; cy < columns; ++cy)
    for (int cx = 0; cx < columns; ++cx) column(base.x + (cx + 0.5f) * step, base.y + (cy + 0.5f) * step, false);
  // The finer lattice under roofs: a column whose centre is a coarse column's (an odd whole ratio
  // of the spacings) is not cast again.
  const int fine = std::max(1, int(std::lround(kSectorSizeM / s.covered_column_spacing_m)));
  if (fine > columns) {
    const int ratio = fine % columns == 0 && (fine / columns) % 2 == 1 ? fine / columns : 0;
    const float fine_step = float(kSectorSizeM / fine);
    for (int cy = 0; cy < fine; ++cy)
      for (int cx = 0; cx < fine; ++cx)
        if (ratio == 0 || cx % ratio != ratio / 2 || cy % ratio != ratio / 2)
          column(base.x + (cx + 0.5f) * fine_step, base.y + (cy + 0.5f) * fine_step, true);
  }
  // 1b. Objects smaller than the column spacing (a 1 m glTF box between the 4 m columns) would
  // leave their sector without a probe and the whole bake empty. When no column found static
  // geometry but some static triangle overlaps the sector, one more column through the centre of
  // those triangles' bounds (clipped to the sector) gives them their probe. Sectors that any
  // column hit are unchanged.
  if (cands.empty()) {
    const glm::vec2 lo = base, hi = base + glm::vec2(float(kSectorSizeM));
    glm::vec2 bmin(INFINITY), bmax(-INFINITY);
    for (size_t tri = 0; tri < geometry.triangleCount(); ++tri) {
      if (!isStatic(geometry.cls[tri])) continue;
      const glm::vec3* v = &geometry.vertices[3 * tri];
      const glm::vec2 tmin = glm::min(glm::min(glm::vec2(v[0]), glm::vec2(v[1])), glm::vec2(v[2]));
      const glm::vec2 tmax = glm::max(glm::max(glm::vec2(v[0]), glm::vec2(v[1])), glm::vec2(v[2]));
      if (tmax.x < lo.x || tmax.y < lo.y || tmin.x >= hi.x || tmin.y >= hi.y) continue;
      bmin = glm::min(bmin, glm::max(tmin, lo));
      bmax = glm::max(bmax, glm::min(tmax, hi));
    }
    if (bmin.x <= bmax.x && bmin.y <= bmax.y) column(0.5f * (bmin.x + bmax.x), 0.5f * (bmin.y + bmax.y), false);
  }

  // 2. Vegetation pass: the top of every vegetation box under the ray.
  const int veg_columns = std::max(1, int(std::lround(kSectorSizeM / s.vegetation_spacing_m)));
  const float veg_step = float(kSectorSizeM / veg_columns);
  for (int cy = 0; cy < veg_columns; ++cy)
    for (int cx = 0; cx < veg_columns; ++cx) {
      const float x = base.x + (cx + 0.5f) * veg_step, y = base.y + (cy + 0.5f) * veg_step;
      for (const raytrace::Box& b : geometry.vegetation_boxes) {
        if (x < b.min.x || x > b.max.x || y < b.min.y || y > b.max.y) continue;
        cands.push_back({glm::vec3(x, y, b.max.z + float(s.lift_m)), kVegetation, order++, kProbeVegetation});
        ++stats.vegetation_candidates;
      }
    }

  // 1c. The enclosed lattice (after every other column, so that their candidates' order, which
  // keys their inside tests, is that of the builds before): covered hits, kept in step 4 only if
  // enclosed. Not cast unless finer than the coarse and covered lattices. It runs through the
  // coarse columns (not cast again), so that with the coarse lattice's probes it is one lattice:
  // offset by half a step, every point of a 2 m lattice was within 1.41 m of a coarse probe and
  // a 2 m least distance rejected them all.
  const double enclosed_spacing = std::min(s.enclosed_column_spacing_m, s.covered_column_spacing_m);
  const int enclosed_columns = std::max(1, int(std::lround(kSectorSizeM / enclosed_spacing)));
  if (enclosed_columns > std::max(columns, fine)) {
    const float enclosed_step = float(kSectorSizeM / enclosed_columns);
    const float offset = std::fmod(0.5f * step, enclosed_step);
    auto coarse = [&](float v) {  // on a coarse column's line
      const float u = v / step - 0.5f;
      return std::fabs(u - std::round(u)) < 1e-4f;
    };
    for (int cy = 0; cy < enclosed_columns; ++cy)
      for (int cx = 0; cx < enclosed_columns; ++cx) {
        const float x = offset + float(cx) * enclosed_step, y = offset + float(cy) * enclosed_step;
        if (coarse(x) && coarse(y)) continue;
        column(base.x + x, base.y + y, true, true);
      }
  }

  // 4. Inside and clearance test (before the distance test, so that a moved probe competes fairly).
  const bool enclosed_finer = s.enclosedDenser();
  std::vector<Candidate> kept;
  kept.reserve(cands.size());
  for (Candidate& c : cands) {
    const uint64_t key = raytrace::hashKey(sector_key, c.order);
    const Surroundings here = surroundings(scene, geometry, c.position, s, key, stats);
    // Enclosed: a covered candidate with walls all round (where it is kept), tested only where the
    // enclosed spacing is finer than the covered one.
    auto keep = [&](Candidate& k) {
      k.enclosed = enclosed_finer && k.priority == kCovered && enclosed(scene, geometry, k.position, stats);
      if (k.enclosed_only && !k.enclosed) return;
      kept.push_back(k);
    };
    if (here.clear(s.clearance_m)) {
      keep(c);
      continue;
    }
    bool moved = false;
    for (size_t o = 0; o < std::size(kRelocationOffsets) && !moved; ++o) {
      const glm::vec3 p = c.position + kRelocationOffsets[o];
      if (p.x < base.x || p.y < base.y || p.x >= base.x + float(kSectorSizeM) || p.y >= base.y + float(kSectorSizeM)) continue;
      // A covered candidate stays under the surface that covers it: lifted through the ceiling it
      // stood in the storey above or on the roof, still flagged covered (15 of the 806 covered
      // probes of the town test's 8-storey block stood on its roof, 2026-12-07).
      if (s.covered_stays_under && p.z > c.ceiling - float(s.clearance_m)) continue;
      if (surroundings(scene, geometry, p, s, raytrace::hashKey(key, o + 1), stats).clear(s.clearance_m)) {
        c.position = p;
        c.flags |= kProbeRelocated;
        keep(c);
        moved = true;
      }
    }
    if (moved)
      ++stats.relocated;
    else if (here.inside)
      ++stats.dropped_inside;
    else
      ++stats.dropped_gap;
  }

  // 3. Interiors' designated probes, kept unconditionally.
  for (const LocalInterior& in : interiors) {
    const glm::vec3 p = in.probe_position;
    if (p.x < base.x || p.y < base.y || p.x >= base.x + float(kSectorSizeM) || p.y >= base.y + float(kSectorSizeM)) continue;
    kept.push_back({p, kDesignated, order++, kProbeInterior, in.index});
    ++stats.interior_probes;
  }

  // 7 (first, for the cap of 6): the light sources, those under static geometry only.
  std::vector<glm::vec3> lights;
  for (const glm::vec3& l : light_sources) {
    DRTV_CHECK(l.x >= base.x && l.y >= base.y && l.x <= base.x + float(kSectorSizeM) && l.y <= base.y + float(kSectorSizeM));
    const float up = std::max(0.f, geometry.z_max - l.z) + 1.f;
    if (std::isfinite(detail::staticHitDistance(scene, geometry, l, glm::vec3(0, 0, 1), up, kMaxHitsPerColumn, stats.rays))) lights.push_back(l);
  }

  // 5 and 6. Minimum distance, then the cap.
  std::stable_sort(kept.begin(), kept.end(), [](const Candidate& a, const Candidate& b) {
    return a.priority != b.priority ? a.priority < b.priority : a.order < b.order;
  });
  const double covered_h0 = std::min(s.covered_min_horizontal_m, s.min_horizontal_m);
  const LeastDistances least{s.min_horizontal_m, covered_h0, std::min(s.enclosed_min_horizontal_m, covered_h0)};
  LeastDistances now = least;
  // One ray a pair, kept: step 6 runs step 5 again with the same pairs in reach.
  std::unordered_map<uint64_t, bool> sight_between;
  auto hidden = [&](const Candidate& a, const Candidate& b) {
    if (!s.covered_sight) return false;
    const uint64_t key = (uint64_t(std::min(a.order, b.order)) << 32) | std::max(a.order, b.order);
    const auto [it, fresh] = sight_between.try_emplace(key, false);
    if (fresh) {
      const glm::vec3 d = b.position - a.position;
      const float len = glm::length(d);
      it->second = len > 0.f && std::isfinite(detail::staticHitDistance(scene, geometry, a.position, d / len, len, kMaxHitsPerColumn, stats.rays));
    }
    return it->second;
  };
  std::vector<Candidate> accepted = greedy(kept, now, least, s.min_vertical_m, hidden);
  stats.rejected_distance += kept.size() - accepted.size();
  const size_t first_pass = accepted.size();
  const size_t cap = size_t(kMaxProbesPerSector) - lights.size();
  while (accepted.size() > cap && now.open < kSectorSizeM) {
    if (s.thin_near_first && now.enclosed < now.open) {  // the denser two first, up to the open one
      now.covered = std::min(now.covered * 1.25, now.open);
      now.enclosed = std::min(now.enclosed * 1.25, now.covered);
    } else {
      now.open *= 1.25;
      now.covered *= 1.25;
      now.enclosed *= 1.25;
    }
    accepted = greedy(kept, now, least, s.min_vertical_m, hidden);
  }
  if (accepted.size() > cap) accepted.resize(cap);
  stats.thinned_cap += first_pass - accepted.size();

  std::vector<PlacedProbe> out;
  out.reserve(accepted.size());
  for (const Candidate& c : accepted) {
    PlacedProbe p{c.position, c.flags, c.interior};
    if (c.priority == kCovered || c.priority == kDesignated) p.flags |= kProbeCovered;
    if (p.interior == 0)
      for (const LocalInterior& in : interiors)
        if (in.box.contains(p.position)) {
          p.interior = in.index;
          break;
        }
    out.push_back(p);
  }
  for (const glm::vec3& l : lights) out.push_back({l, kProbeLightSource, 0});
  return out;
}

}  // namespace drtv::baker
