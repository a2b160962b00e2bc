// Ranking of sectors for residency (see residency.h for the rule and its references).
#include "drtv/streamer/residency.h"

#include <algorithm>
#include <array>
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

// Slab test: narrows [t0, t1] = [0, 1] to the part of the segment a + t (b - a) between each pair
// of r's lines, closed or open (touching is not inside); true when some of it is left. A segment
// that does not move along an axis keeps all of it or nothing.
bool clipToRect(const glm::dvec2& a, const glm::dvec2& b, const Rect& r, bool open, double& t0, double& t1) {
  t0 = 0.0, t1 = 1.0;
  for (int axis = 0; axis < 2; ++axis) {
    const double d = b[axis] - a[axis];
    if (d == 0.0) {
      const bool inside = open ? a[axis] > r.min[axis] && a[axis] < r.max[axis] : !(a[axis] < r.min[axis] || a[axis] > r.max[axis]);
      if (!inside) return false;
      continue;
    }
    double ta = (r.min[axis] - a[axis]) / d, tb = (r.max[axis] - a[axis]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return open ? t0 < t1 : !(t0 > t1);
}

// Does the segment [a, b] pass through the closed rectangle?
bool segmentHitsRect(const glm::dvec2& a, const glm::dvec2& b, const Rect& r) {
  double t0, t1;
  return clipToRect(a, b, r, /*open=*/false, t0, t1);
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

namespace {

// When the footprint about p = a + t (b - a) first overlaps the sector's open square: p lies in
// the square grown by the footprint's half size (open). -1 when it never does for t in [0, 1].
double footprintEntry(SectorKey key, const glm::dvec2& half, const glm::dvec2& a, const glm::dvec2& b) {
  const Rect r = sectorRect(key);
  double t0, t1;
  return clipToRect(a, b, {r.min - half, r.max + half}, /*open=*/true, t0, t1) ? t0 : -1.0;
}

// Camera::path_ahead's points the ranking follows at most; past them the track goes straight on
// along the last one's step.
constexpr size_t kMaxPathPoints = 126;

// The camera's predicted track as a polyline of (position, time) corners from now to `end_s`:
// the camera, then Camera::path_ahead's points up to the first at or past end_s (or the
// kMaxPathPoints-th), then straight on along the last step if they stop short of end_s; without a
// path, the straight line along the velocity.

class Track {
 public:
  Track(const Camera& c, double end_s) : c_(c), end_s_(end_s) {
    const bool path = !c.path_ahead.empty() && c.path_step_s > 0.0 && std::isfinite(c.path_step_s);
    // In double first: a tiny step or a NaN end would not fit a size_t.
    const double wanted = std::ceil(end_s / c.path_step_s);
    n_ = path ? std::min(c.path_ahead.size(), wanted < double(kMaxPathPoints) ? size_t(std::max(wanted, 0.0)) : kMaxPathPoints) : 0;
    tail_ = n_ == 0 || double(n_) * c.path_step_s < end_s;
    if (n_ > 0) {
      const glm::dvec2 prev = n_ >= 2 ? xy(c.path_ahead[n_ - 2]) : xy(c.position_m);
      tail_v_ = (xy(c.path_ahead[n_ - 1]) - prev) / c.path_step_s;
    } else {
      tail_v_ = xy(c.velocity_mps);
    }
  }
  // Corners 0 .. corners() - 1 in time order; corner 0 is the camera now. The track reaches end_s
  // (a path's last point used may lie past it).
  size_t corners() const { return n_ + 1 + (tail_ ? 1 : 0); }
  bool followsPath() const { return n_ > 0; }
  double time(size_t i) const { return i == 0 ? 0.0 : i <= n_ ? double(i) * c_.path_step_s : end_s_; }
  glm::dvec2 at(size_t i) const {
    if (i == 0) return xy(c_.position_m);
    if (i <= n_) return xy(c_.path_ahead[i - 1]);
    const glm::dvec2 last = n_ ? xy(c_.path_ahead[n_ - 1]) : xy(c_.position_m);
    return last + tail_v_ * (end_s_ - (n_ ? double(n_) * c_.path_step_s : 0.0));
  }

 private:
  static glm::dvec2 xy(const glm::dvec3& p) { return {p.x, p.y}; }
  const Camera& c_;
  double end_s_;
  size_t n_ = 0;
  bool tail_ = true;
  glm::dvec2 tail_v_{0.0};
};

}  // namespace

void rankSectors(const Manifest& manifest, const Camera& camera, const ResidencyOptions& o,
                 std::span<const SectorKey> held, std::vector<RankedSector>& out) {
  out.clear();
  // The footprint swept along the track from now to the end of the guard or the look-ahead,
  // whichever is later: a sector's time of need is when the moving footprint first overlaps it.
  const double sweep_s = std::max({o.guard_s, o.lookahead_s, 0.0});
  const Track track(camera, sweep_s);
  const Footprint now = volumeFootprint(camera.position_m, o);
  const glm::dvec2 half = 0.5 * (now.max - now.min);
  const glm::dvec2 tolerance(track.followsPath() && camera.path_tolerance_m > 0.0 ? std::min(camera.path_tolerance_m, kSectorSizeM) : 0.0);
  const double speed = glm::length(glm::dvec2(camera.velocity_mps.x, camera.velocity_mps.y));
  const double r = o.candidate_radius_m;
  const double reach = std::max({r, half.x, half.y});  // tier 0 lies within the footprint's reach of the sweep
  // The track's segments once, each with its bounding box (the sectors test it first: most of
  // them lie far from most segments). The look-ahead's: the track up to lookahead_s, cut there.
  struct Seg {
    glm::dvec2 a, b, lo, hi;  // ends; bounding box
    double t0, t1;
    glm::dvec2 la_b;          // the look-ahead's end of this segment (b, or cut at lookahead_s)
    bool look_ahead;          // part of the look-ahead
  };
  constexpr size_t kMaxSegments = kMaxPathPoints + 1;  // the points, and the tail past them
  std::array<Seg, kMaxSegments> segs;
  size_t n_segs = 0;
  glm::dvec2 lo = track.at(0), hi = lo;
  for (size_t i = 0; i + 1 < track.corners(); ++i) {
    Seg& g = segs[n_segs++];
    g.a = track.at(i), g.b = track.at(i + 1), g.t0 = track.time(i), g.t1 = track.time(i + 1);
    g.lo = glm::min(g.a, g.b), g.hi = glm::max(g.a, g.b);
    g.look_ahead = g.t0 < o.lookahead_s || i == 0;
    const double f = g.t1 > o.lookahead_s && g.t1 > g.t0 ? std::max(0.0, (o.lookahead_s - g.t0) / (g.t1 - g.t0)) : 1.0;
    g.la_b = g.a + (g.b - g.a) * f;
    lo = glm::min(lo, g.lo), hi = glm::max(hi, g.hi);
  }
  const glm::dvec2 grown = half + tolerance;
  const KeyBox box = clipToManifest(manifest, {floorKey(lo.x - reach), floorKey(lo.y - reach), floorKey(hi.x + reach), floorKey(hi.y + reach)});
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (int32_t ix = box.x0; ix <= box.x1; ++ix)
    for (int32_t iy = box.y0; iy <= box.y1; ++iy) {
      const SectorKey key{ix, iy};
      const SectorEntry* e = manifest.find(key);
      if (!e) continue;
      const Rect rect = sectorRect(key);
      // Time of need: the first segment whose swept footprint overlaps the sector.
      double need_s = kInf;
      for (size_t i = 0; i < n_segs; ++i) {
        const Seg& g = segs[i];
        if (g.lo.x >= rect.max.x + grown.x || g.hi.x <= rect.min.x - grown.x || g.lo.y >= rect.max.y + grown.y ||
            g.hi.y <= rect.min.y - grown.y)
          continue;
        if (const double entry = footprintEntry(key, grown, g.a, g.b); entry >= 0.0) {
          need_s = g.t0 + entry * (g.t1 - g.t0);
          break;
        }
      }
      // Distance to the look-ahead; a segment whose box lies farther than the best so far (or
      // than the candidate radius) cannot be nearer.
      double d = kInf;
      for (size_t i = 0; i < n_segs && d > 0.0; ++i) {
        const Seg& g = segs[i];
        if (!g.look_ahead) break;
        const glm::dvec2 blo = glm::min(g.a, g.la_b), bhi = glm::max(g.a, g.la_b);
        const double gx = std::max({rect.min.x - bhi.x, blo.x - rect.max.x, 0.0}), gy = std::max({rect.min.y - bhi.y, blo.y - rect.max.y, 0.0});
        const double bound = std::sqrt(gx * gx + gy * gy);
        if (bound >= d || bound > r) continue;
        d = std::min(d, distanceToSegment(key, g.a, g.la_b));
      }
      const int tier = need_s <= o.guard_s ? 0 : 1;
      if (tier == 1 && !(d <= r)) continue;
      const bool is_held = std::binary_search(held.begin(), held.end(), key);
      // Tier 0 in the order the footprint reaches the sectors (metres of travel until needed);
      // tier 1 by distance to the look-ahead; ties by time of need, then distance, then key.
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
