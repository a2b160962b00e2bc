// Ranking of sectors for residency (see residency.h for the rule and its references).
#include "drtv/streamer/residency.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace drtv::streamer {
namespace {

struct Rect {
  glm::dvec2 min, max;
};

Rect sectorRect(SectorKey key) {
  const glm::dvec2 lo{double(key.ix) * kSectorSizeM, double(key.iy) * kSectorSizeM};
  return {lo, lo + glm::dvec2(kSectorSizeM)};
}

double pointToRect(const glm::dvec2& p, const Rect& r) {
  const double dx = std::max({r.min.x - p.x, 0.0, p.x - r.max.x});
  const double dy = std::max({r.min.y - p.y, 0.0, p.y - r.max.y});
  return std::sqrt(dx * dx + dy * dy);
}

double pointToSegment(const glm::dvec2& p, const glm::dvec2& a, const glm::dvec2& b) {
  const glm::dvec2 ab = b - a;
  const double len2 = glm::dot(ab, ab);
  const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * ab));
}

// Slab test: does the segment [a, b] pass through the closed rectangle?
bool segmentHitsRect(const glm::dvec2& a, const glm::dvec2& b, const Rect& r) {
  double t0 = 0.0, t1 = 1.0;
  for (int axis = 0; axis < 2; ++axis) {
    const double d = b[axis] - a[axis];
    if (std::abs(d) < 1e-12) {
      if (a[axis] < r.min[axis] || a[axis] > r.max[axis]) return false;
      continue;
    }
    double ta = (r.min[axis] - a[axis]) / d, tb = (r.max[axis] - a[axis]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// The manifest's key range, so that enumeration never walks empty sea.
struct KeyBox {
  int32_t x0, y0, x1, y1;  // inclusive
};
KeyBox clipToManifest(const Manifest& m, KeyBox box) {
  if (m.sectors.empty()) return {1, 1, 0, 0};
  int32_t mx0 = INT32_MAX, my0 = INT32_MAX, mx1 = INT32_MIN, my1 = INT32_MIN;
  // sectors are sorted by (ix, iy): ix range from the ends, iy needs a scan (cheap: <= 10^4).
  mx0 = m.sectors.front().key.ix;
  mx1 = m.sectors.back().key.ix;
  for (const SectorEntry& e : m.sectors) {
    my0 = std::min(my0, e.key.iy);
    my1 = std::max(my1, e.key.iy);
  }
  return {std::max(box.x0, mx0), std::max(box.y0, my0), std::min(box.x1, mx1), std::min(box.y1, my1)};
}

// formats' sectorAt per axis: clamped to int32 and NaN-safe (a camera can hold anything).
int32_t floorKey(double v_m) { return sectorAt(v_m, 0.0).ix; }

}  // namespace

Footprint volumeFootprint(const glm::dvec3& position_m, const ResidencyOptions& o) {
  const glm::dvec2 half = 0.5 * glm::dvec2(o.volume.size.x, o.volume.size.y) *
                          glm::dvec2(o.volume.texel_size_m.x, o.volume.texel_size_m.y);
  const glm::dvec2 c{position_m.x, position_m.y};
  return {c - half, c + half};
}

bool overlaps(SectorKey key, const Footprint& f) {
  const Rect r = sectorRect(key);
  return r.min.x < f.max.x && f.min.x < r.max.x && r.min.y < f.max.y && f.min.y < r.max.y;
}

double distanceToSegment(SectorKey key, const glm::dvec2& a, const glm::dvec2& b) {
  const Rect r = sectorRect(key);
  if (segmentHitsRect(a, b, r)) return 0.0;
  // Disjoint convex shapes: the distance is attained at a vertex of one of them.
  double d = std::min(pointToRect(a, r), pointToRect(b, r));
  const glm::dvec2 corners[4] = {r.min, {r.max.x, r.min.y}, {r.min.x, r.max.y}, r.max};
  for (const auto& c : corners) d = std::min(d, pointToSegment(c, a, b));
  return d;
}

double footprintEntry(SectorKey key, const glm::dvec2& half, const glm::dvec2& a, const glm::dvec2& b) {
  // The footprint about p overlaps the sector's open square iff p lies in the square grown by the
  // footprint's half size (open): a slab test of the segment against that rectangle.
  const Rect r = sectorRect(key);
  const Rect g{r.min - half, r.max + half};
  double t0 = 0.0, t1 = 1.0;
  for (int axis = 0; axis < 2; ++axis) {
    const double d = b[axis] - a[axis];
    if (d == 0.0) {
      if (!(a[axis] > g.min[axis] && a[axis] < g.max[axis])) return -1.0;
      continue;
    }
    double ta = (g.min[axis] - a[axis]) / d, tb = (g.max[axis] - a[axis]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  // Open rectangle: touching at one instant is no overlap. NaN (a camera holding anything) fails.
  return t0 < t1 ? t0 : -1.0;
}

void rankSectors(const Manifest& manifest, const Camera& camera, const ResidencyOptions& o,
                 std::span<const SectorKey> held, std::vector<RankedSector>& out) {
  out.clear();
  const glm::dvec2 a{camera.position_m.x, camera.position_m.y};
  const glm::dvec2 v{camera.velocity_mps.x, camera.velocity_mps.y};
  const glm::dvec2 b = a + v * o.lookahead_s;
  // The footprint swept from now to the end of the guard or the look-ahead, whichever is later:
  // a sector's time of need is when the moving footprint first overlaps it.
  const double sweep_s = std::max({o.guard_s, o.lookahead_s, 0.0});
  const glm::dvec2 sweep_end = a + v * sweep_s;
  const Footprint now = volumeFootprint(camera.position_m, o);
  const glm::dvec2 half = 0.5 * (now.max - now.min);
  const double speed = glm::length(v);
  const double r = o.candidate_radius_m;
  const double reach = std::max({r, half.x, half.y});  // tier 0 lies within the footprint's reach of the sweep
  const KeyBox box = clipToManifest(manifest, {floorKey(std::min(a.x, sweep_end.x) - reach), floorKey(std::min(a.y, sweep_end.y) - reach),
                                               floorKey(std::max(a.x, sweep_end.x) + reach), floorKey(std::max(a.y, sweep_end.y) + reach)});
  for (int32_t ix = box.x0; ix <= box.x1; ++ix)
    for (int32_t iy = box.y0; iy <= box.y1; ++iy) {
      const SectorKey key{ix, iy};
      const SectorEntry* e = manifest.find(key);
      if (!e) continue;
      const double entry = footprintEntry(key, half, a, sweep_end);
      const double need_s = entry >= 0.0 ? entry * sweep_s : std::numeric_limits<double>::infinity();
      const int tier = need_s <= o.guard_s ? 0 : 1;
      const double d = distanceToSegment(key, a, b);
      if (tier == 1 && d > r) continue;
      const bool is_held = std::binary_search(held.begin(), held.end(), key);
      // Tier 0 in the order the footprint reaches the sectors (metres of travel until needed);
      // tier 1 by distance to the look-ahead segment; ties by time of need, then distance, then key.
      const double base = tier == 0 ? need_s * speed : d;
      out.push_back({key, tier, d, base - (is_held ? o.hysteresis_m : 0.0), need_s, e});
    }
  std::sort(out.begin(), out.end(), [](const RankedSector& x, const RankedSector& y) {
    if (x.tier != y.tier) return x.tier < y.tier;
    if (x.score_m != y.score_m) return x.score_m < y.score_m;
    if (x.need_s != y.need_s) return x.need_s < y.need_s;
    if (x.distance_m != y.distance_m) return x.distance_m < y.distance_m;
    return x.key < y.key;
  });
}

void footprintSectors(const Manifest& manifest, const glm::dvec3& position_m, const ResidencyOptions& o,
                      std::vector<SectorKey>& out) {
  out.clear();
  const Footprint f = volumeFootprint(position_m, o);
  // Open footprint: a footprint edge on a sector boundary does not reach the next sector.
  const KeyBox box = clipToManifest(manifest, {floorKey(f.min.x), floorKey(f.min.y), floorKey(std::nextafter(f.max.x, -1e300)),
                                               floorKey(std::nextafter(f.max.y, -1e300))});
  for (int32_t ix = box.x0; ix <= box.x1; ++ix)
    for (int32_t iy = box.y0; iy <= box.y1; ++iy)
      if (manifest.find({ix, iy}) && overlaps({ix, iy}, f)) out.push_back({ix, iy});
}

SectorRange residentBlock(const glm::dvec3& position_m) {
  const SectorKey c = sectorAt(position_m.x, position_m.y);
  auto clamped = [](int64_t v) {
    return int32_t(std::clamp<int64_t>(v, std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max()));
  };
  return {clamped(int64_t(c.ix) - kResidentBlockRadius), clamped(int64_t(c.ix) + kResidentBlockRadius),
          clamped(int64_t(c.iy) - kResidentBlockRadius), clamped(int64_t(c.iy) + kResidentBlockRadius)};
}

}  // namespace drtv::streamer
