// surface_cells.h — the transfer bake's surface cache cells (transfer.h, "The surface cache"):
// the key of a surface point, the map from keys to surfels, and the sides of the walls that cross
// a cell (TransferSettings::cell_sides). Private to drtv::baker (transfer.cpp).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "drtv/baker/transfer.h"
#include "drtv/formats/error.h"
#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/sampling.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker::detail::cells {

inline constexpr uint64_t kEscaped = ~0ull;
inline constexpr uint64_t kBackface = ~0ull - 1;
inline constexpr uint32_t kNoSurfel = ~0u;
inline constexpr uint32_t kPending = ~0u - 1;  // an edge whose cell is created after the trace

// The cache key of a surface point: 20 bits per cell coordinate (offset so that negatives fit),
// 3 bits for the dominant axis and sign of the front normal. Exact, no collisions for any world
// the baker accepts (+-2^19 cells of >= 0.25 m is +-131 km).
// floor() without a call: on the x86-64 baseline std::floor(float) is a libm call (no SSE4.1
// roundss), and cell keys are computed for every ray hit (3% of a bake's CPU time).
// Precondition: |v| < 2^62 (hit positions are finite and inside the world's bounds).
inline int64_t floorToInt(float v) {
  const int64_t t = int64_t(v);  // truncates toward zero
  return t - int64_t(float(t) > v);
}

inline uint64_t cellKey(const glm::vec3& p, const glm::vec3& n, float inv_cell) {
  auto q = [&](float v) { return uint64_t(floorToInt(v * inv_cell) + (1 << 19)) & 0xfffffull; };
  const glm::vec3 a = glm::abs(n);
  const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
  const uint64_t bucket = uint64_t(axis * 2 + (n[axis] < 0.f ? 1 : 0));
  return q(p.x) | (q(p.y) << 20) | (q(p.z) << 40) | (bucket << 60);
}

// Open-addressing hash map uint64 -> uint32 (linear probing; keys never equal kEscaped).
class CellMap {
 public:
  CellMap() { rehash(1 << 12); }
  uint32_t find(uint64_t key) const {
    for (size_t i = raytrace::mix64(key) & mask_;; i = (i + 1) & mask_) {
      if (keys_[i] == key) return vals_[i];
      if (keys_[i] == kEscaped) return kNoSurfel;
    }
  }
  // Inserts (key, value) if absent; returns the value stored.
  uint32_t insert(uint64_t key, uint32_t value) {
    if (2 * (size_ + 1) > keys_.size()) rehash(keys_.size() * 2);
    for (size_t i = raytrace::mix64(key) & mask_;; i = (i + 1) & mask_) {
      if (keys_[i] == key) return vals_[i];
      if (keys_[i] == kEscaped) {
        keys_[i] = key;
        vals_[i] = value;
        ++size_;
        return value;
      }
    }
  }

 private:
  void rehash(size_t n) {
    std::vector<uint64_t> old_keys = std::move(keys_);
    std::vector<uint32_t> old_vals = std::move(vals_);
    keys_.assign(n, kEscaped);
    vals_.assign(n, 0);
    mask_ = n - 1;
    size_ = 0;
    for (size_t i = 0; i < old_keys.size(); ++i)
      if (old_keys[i] != kEscaped) insert(old_keys[i], old_vals[i]);
  }
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> vals_;
  size_t mask_ = 0, size_ = 0;
};

struct Surfel {
  glm::vec3 position;
  glm::vec3 normal;
};

// The surface cache's cells (transfer.h): a cell key names its first surfel, and each surfel the
// next of its key, one per side of the walls that cross the cell (TransferSettings::cell_sides).
class SurfaceCells {
 public:
  SurfaceCells(const raytrace::RayScene& scene, bool sides) : scene_(scene), sides_(sides) {}
  bool sides() const { return sides_; }

  // With sides: the cubes that a static triangle (a wall, a floor, a roof), its bounds grown by
  // kCellSideOffsetM, reaches, within the sector's halo. Only there is a cell split: elsewhere
  // lie terrain and vegetation alone, taken as one side (a heightfield's points see each other
  // but over a ridge or a step sharper than a cell; a canopy is no wall, and splitting the ground
  // under every tree from the ground beside it cost the island 4.6 M rays and 1.1-1.2x its bake
  // for no change in its error), and a hit there casts no side ray.
  void markObjects(const raytrace::SectorGeometry& g, float inv_cell) {
    if (!sides_) return;
    auto cube = [&](float v) { return floorToInt(v * inv_cell); };
    const float lo_xy = float(-g.halo_m), hi_xy = float(kSectorSizeM + g.halo_m);
    const glm::vec3 lo_bound(lo_xy, lo_xy, g.z_min - kCellSideOffsetM), hi_bound(hi_xy, hi_xy, g.z_max + kCellSideOffsetM);
    origin_ = {cube(lo_bound.x), cube(lo_bound.y), cube(lo_bound.z)};
    for (int a = 0; a < 3; ++a) dims_[a] = cube(hi_bound[a]) - origin_[a] + 1;
    const int64_t cubes = dims_[0] * dims_[1] * dims_[2];
    if (cubes > kMaxMarkedCubes) return;  // a world too tall for the bitmap: every cube may have sides
    busy_.assign(size_t(cubes), 0);
    for (size_t t = 0; t < g.triangleCount(); ++t) {
      if (g.cls[t] != uint8_t(worlds::InstanceClass::kStatic)) continue;
      const glm::vec3 &a = g.vertices[3 * t], &b = g.vertices[3 * t + 1], &c = g.vertices[3 * t + 2];
      const glm::vec3 lo = glm::max(glm::min(glm::min(a, b), c) - kCellSideOffsetM, lo_bound);
      const glm::vec3 hi = glm::min(glm::max(glm::max(a, b), c) + kCellSideOffsetM, hi_bound);
      if (glm::any(glm::greaterThan(lo, hi))) continue;
      for (int64_t z = cube(lo.z); z <= cube(hi.z); ++z)
        for (int64_t y = cube(lo.y); y <= cube(hi.y); ++y)
          for (int64_t x = cube(lo.x); x <= cube(hi.x); ++x) busy_[size_t(index(x, y, z))] = 1;
    }
  }
  // Whether cell `key` can have more than one side (markObjects).
  bool mayHaveSides(uint64_t key) const {
    if (!sides_) return false;
    if (busy_.empty()) return true;
    auto axis = [&](int a) { return int64_t((key >> (20 * a)) & 0xfffffull) - (1 << 19); };
    const int64_t x = axis(0), y = axis(1), z = axis(2);
    if (x < origin_[0] || y < origin_[1] || z < origin_[2] || x >= origin_[0] + dims_[0] || y >= origin_[1] + dims_[1] ||
        z >= origin_[2] + dims_[2])
      return true;  // outside what was marked: as if busy
    return busy_[size_t(index(x, y, z))] != 0;
  }
  // Whether a hit at (p, n) and one at (q, m) lie on one side of whatever crosses their cell:
  // their points kCellSideOffsetM off their surfaces see each other. Always, without sides.
  // `rays` counts the occlusion rays cast.
  bool sameSide(const glm::vec3& p, const glm::vec3& n, const glm::vec3& q, const glm::vec3& m, uint64_t& rays) const {
    raytrace::Ray ray;
    if (!sides_ || !sideRay(p, n, q, m, ray)) return true;
    ++rays;
    return !scene_.occluded(ray);
  }
  // The segment sameSide tests, in `ray`; false when the two points coincide (a hit is its own
  // surfel's: one side).
  static bool sideRay(const glm::vec3& p, const glm::vec3& n, const glm::vec3& q, const glm::vec3& m, raytrace::Ray& ray) {
    const glm::vec3 a = p + kCellSideOffsetM * n;
    const glm::vec3 d = q + kCellSideOffsetM * m - a;
    const float len = glm::length(d);
    if (len < 1e-4f) return false;
    ray = raytrace::Ray{a, 0.f, d / len, len};
    return true;
  }
  // The first surfel of cell `key` (kNoSurfel: none yet), and the next side of surfel `id`'s.
  uint32_t first(uint64_t key) const { return map_.find(key); }
  void occluded(std::span<const raytrace::Ray> rays, std::span<uint8_t> blocked) const { scene_.occluded(rays, blocked); }
  uint32_t next(uint32_t id) const { return next_[id]; }
  // The surfel on the side of a hit at (p, n) among the sides of its cell from `id` on: the first,
  // in the order they were made, on its side; kNoSurfel if none, and then `sides` has been
  // counted up by those it passed. Const: any number of threads.
  uint32_t find(uint32_t id, const glm::vec3& p, const glm::vec3& n, const std::vector<Surfel>& surfels, uint64_t& rays,
                uint32_t& sides) const {
    for (; id != kNoSurfel; id = next_[id], ++sides)
      if (sameSide(p, n, surfels[id].position, surfels[id].normal, rays)) return id;
    return kNoSurfel;
  }
  // The surfel of side `side` of cell `key` (sides counted in the order they were made);
  // `make()` makes a new surfel, which must be the next id, when `side` is the key's next side.
  template <typename Make>
  uint32_t side(uint64_t key, uint32_t side, Make make) {
    uint32_t id = map_.find(key), last = kNoSurfel;
    for (uint32_t k = 0; id != kNoSurfel; id = next_[id], ++k) {
      if (k == side) return id;
      last = id;
    }
    const uint32_t made = make();
    DRTV_CHECK_EQ(size_t(made), next_.size());  // ids are made in order, one per (key, side)
    next_.push_back(kNoSurfel);
    if (last == kNoSurfel) {
      DRTV_CHECK_EQ(side, 0u);  // a key's sides are first seen in order
      map_.insert(key, made);
    } else {
      DRTV_CHECK(side != 0);
      next_[last] = made;
    }
    return made;
  }

 private:
  // The most cubes markObjects keeps a byte for (16 MiB a sector task: 3.6 km of height at 2 m
  // cells); beyond, every cube may have sides.
  static constexpr int64_t kMaxMarkedCubes = int64_t(1) << 24;
  int64_t index(int64_t x, int64_t y, int64_t z) const {
    return ((z - origin_[2]) * dims_[1] + (y - origin_[1])) * dims_[0] + (x - origin_[0]);
  }
  const raytrace::RayScene& scene_;
  bool sides_;
  std::array<int64_t, 3> origin_{}, dims_{};  // the marked cubes' first cube and extent
  std::vector<uint8_t> busy_;                 // 1 per cube an object reaches (markObjects)
  CellMap map_;
  std::vector<uint32_t> next_;
};

// For hits `at(i)` in cells `key(i)` (kEscaped or kBackface: none), in their order: which of the
// new sides of its cell each lies on, counted per key from 0 in the order the hits first show
// them (the sides the cell already has are the caller's). Keys are resolved in parallel, each
// key's hits in order, so the answer does not depend on threads.
template <typename Key, typename At>
std::vector<uint32_t> sidesOfHits(const SurfaceCells& cells, size_t count, Key key, At at, std::atomic<uint64_t>& rays) {
  std::vector<uint32_t> side(count, 0);
  if (!cells.sides()) return side;
  std::vector<std::pair<uint64_t, uint32_t>> order;
  for (size_t i = 0; i < count; ++i)
    if (key(i) < kBackface && cells.mayHaveSides(key(i))) order.emplace_back(key(i), uint32_t(i));  // else side 0
  std::sort(order.begin(), order.end());
  std::vector<size_t> starts;
  for (size_t i = 0; i < order.size(); ++i)
    if (i == 0 || order[i].first != order[i - 1].first) starts.push_back(i);
  starts.push_back(order.size());
  // Each key's hits against its first side's anchor in one batch of occlusion rays, those on
  // none against the next side's (the first of them), and so on: the sides a serial pass over the
  // hits in order would give.
  tbb::parallel_for(tbb::blocked_range<size_t>(0, starts.size() - 1, 64), [&](const tbb::blocked_range<size_t>& range) {
    uint64_t local = 0;
    std::vector<uint32_t> open, rest, tested;
    std::vector<raytrace::Ray> batch;
    std::vector<uint8_t> blocked;
    for (size_t g = range.begin(); g < range.end(); ++g) {
      open.clear();
      for (size_t j = starts[g]; j < starts[g + 1]; ++j) open.push_back(order[j].second);
      for (uint32_t k = 0; !open.empty(); ++k) {
        const Surfel anchor = at(open[0]);
        side[open[0]] = k;
        batch.clear();
        tested.clear();
        rest.clear();
        for (size_t j = 1; j < open.size(); ++j) {
          const Surfel h = at(open[j]);
          raytrace::Ray ray;
          if (!SurfaceCells::sideRay(h.position, h.normal, anchor.position, anchor.normal, ray)) {
            side[open[j]] = k;
            continue;
          }
          batch.push_back(ray);
          tested.push_back(open[j]);
        }
        blocked.assign(batch.size(), 0);
        if (!batch.empty()) cells.occluded(batch, blocked);
        local += batch.size();
        for (size_t j = 0; j < tested.size(); ++j) (blocked[j] ? rest.push_back(tested[j]) : void(side[tested[j]] = k));
        std::swap(open, rest);
      }
    }
    rays += local;
  });
  return side;
}

}  // namespace drtv::baker::detail::cells
