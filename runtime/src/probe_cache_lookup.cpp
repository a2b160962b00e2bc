// probe_cache_lookup.cpp — part of ProbeCache (probe_cache.h: the references [1-3] and the layout).
// The cells each probe fills, and finding the probe of a position.
#include "drtv/runtime/probe_cache.h"

#include <algorithm>
#include <cmath>

#include "probe_cache_impl.h"
#include "world_limits.h"

namespace drtv::runtime {

using namespace detail;

void ProbeCache::Impl::fillCells(int s) {
  Slot& sl = slots[s];
  sl.fill = sl.nearest;
  // Only the boxes over the sector's square (a city's rooms are thousands; a sector holds few).
  const glm::dvec2 lo = sl.origin, hi = sl.origin + glm::dvec2(kSectorSizeM);
  std::vector<std::pair<glm::dvec3, glm::dvec3>> here;
  for (const auto& b : interior_boxes)
    if (b.first.x < hi.x && b.second.x > lo.x && b.first.y < hi.y && b.second.y > lo.y) here.push_back(b);
  if (!here.empty()) {
    std::array<uint8_t, kGridCells> inside{};
    for (int z = 0; z < kGridDim; ++z)
      for (int y = 0; y < kGridDim; ++y)
        for (int x = 0; x < kGridDim; ++x) {
          const glm::dvec3 c(sl.origin.x + (x + 0.5) * kGridCellSizeM, sl.origin.y + (y + 0.5) * kGridCellSizeM,
                             double(sl.z_min) + (z + 0.5) * double(sl.cell_h));
          inside[size_t(IndexGrid::cellIndex(x, y, z))] = std::any_of(here.begin(), here.end(), [&](const auto& b) {
            return glm::all(glm::greaterThanEqual(c, b.first)) && glm::all(glm::lessThan(c, b.second));
          });
        }
    // Each layer: a breadth-first search over face neighbours from the cells outside every
    // interior, so that a cell inside takes the nearest outside cell's choice at its height.
    std::array<int16_t, kGridDim * kGridDim> from{};
    std::array<bool, kGridDim> wholly_inside{};  // a layer without a cell outside
    std::vector<int> queue;
    for (int z = 0; z < kGridDim; ++z) {
      queue.clear();
      for (int i = 0; i < kGridDim * kGridDim; ++i) {
        const int cell = IndexGrid::cellIndex(i % kGridDim, i / kGridDim, z);
        from[size_t(i)] = inside[size_t(cell)] ? int16_t(-1) : int16_t(i);
        if (!inside[size_t(cell)]) queue.push_back(i);
      }
      wholly_inside[size_t(z)] = queue.empty();
      for (size_t q = 0; q < queue.size(); ++q) {
        const int i = queue[q], x = i % kGridDim, y = i / kGridDim;
        const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
        for (int k = 0; k < 4; ++k) {
          if (nx[k] < 0 || ny[k] < 0 || nx[k] >= kGridDim || ny[k] >= kGridDim) continue;
          const int j = ny[k] * kGridDim + nx[k];
          if (from[size_t(j)] >= 0) continue;
          from[size_t(j)] = from[size_t(i)];
          queue.push_back(j);
        }
      }
      for (int i = 0; i < kGridDim * kGridDim; ++i) {
        const int cell = IndexGrid::cellIndex(i % kGridDim, i / kGridDim, z);
        if (inside[size_t(cell)] && from[size_t(i)] >= 0)
          sl.fill[size_t(cell)] = sl.nearest[size_t(IndexGrid::cellIndex(from[size_t(i)] % kGridDim, from[size_t(i)] / kGridDim, z))];
      }
    }
    // A layer wholly inside (a hall wider than the sector): the first cell above outside.
    for (int y = 0; y < kGridDim; ++y)
      for (int x = 0; x < kGridDim; ++x) {
        int above = -1;
        for (int z = kGridDim - 1; z >= 0; --z) {
          const int cell = IndexGrid::cellIndex(x, y, z);
          if (!inside[size_t(cell)])
            above = sl.nearest[size_t(cell)];
          else if (wholly_inside[size_t(z)] && above >= 0)
            sl.fill[size_t(cell)] = uint8_t(above);
        }
      }
  }
  const int n = sl.count;
  sl.cell_bounds.assign(size_t(n), {uint8_t(kGridDim), uint8_t(kGridDim), uint8_t(kGridDim), 0, 0, 0});
  for (int z = 0; z < kGridDim; ++z)
    for (int y = 0; y < kGridDim; ++y)
      for (int x = 0; x < kGridDim; ++x) {
        const uint8_t p = sl.fill[IndexGrid::cellIndex(x, y, z)];
        if (p >= n) continue;
        std::array<uint8_t, 6>& b = sl.cell_bounds[p];
        const uint8_t c[3] = {uint8_t(x), uint8_t(y), uint8_t(z)};
        for (int a = 0; a < 3; ++a) b[a] = std::min(b[a], c[a]), b[3 + a] = std::max(b[3 + a], c[a]);
      }
}

ProbeCache::WorldBox ProbeCache::cellsNaming(int s, const std::bitset<kSlotProbes>& probes) const {
  DRTV_CHECK(slotUsed(s));
  const Slot& sl = impl_->slots[s];
  glm::ivec3 lo(kGridDim), hi(-1);
  for (int i = 0; i < sl.count; ++i) {
    if (!probes.test(size_t(i))) continue;
    const std::array<uint8_t, 6>& c = sl.cell_bounds[size_t(i)];
    if (c[0] > c[3]) continue;  // no cell names it
    lo = glm::min(lo, glm::ivec3(c[0], c[1], c[2]));
    hi = glm::max(hi, glm::ivec3(c[3], c[4], c[5]));
  }
  WorldBox b;
  if (hi.x < 0) return b;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  b.lo = {sl.origin.x + lo.x * kGridCellSizeM, sl.origin.y + lo.y * kGridCellSizeM,
          lo.z == 0 ? -kInf : sl.z_min + double(lo.z) * sl.cell_h};
  b.hi = {sl.origin.x + (hi.x + 1) * kGridCellSizeM, sl.origin.y + (hi.y + 1) * kGridCellSizeM,
          hi.z == kGridDim - 1 ? kInf : sl.z_min + double(hi.z + 1) * sl.cell_h};
  return b;
}

glm::vec3 shade(Representation r, const BasisColours& c, const glm::vec3& n) {
  if (r == Representation::kShL1) {
    const glm::vec3 e = c[0] + c[1] * n.y + c[2] * n.z + c[3] * n.x;
    return glm::max(e, glm::vec3(0.f));
  }
  const glm::vec4 w = sh::shadingWeights(n);
  return w.x * c[0] + w.y * c[1] + w.z * c[2] + w.w * c[3];
}

ProbeRef ProbeCache::probeAt(const glm::dvec3& pos) const {
  const int s = impl_->slotWithProbes(pos);
  return s < 0 ? ProbeRef{} : ProbeRef{s, impl_->namedProbe(s, pos)};
}

ProbeRef ProbeCache::filledAt(const glm::dvec3& pos) const {
  const int s = impl_->slotWithProbes(pos);
  return s < 0 ? ProbeRef{} : ProbeRef{s, impl_->filledProbe(s, pos)};
}

ProbeRef ProbeCache::interiorProbe(uint16_t index, const glm::dvec3& designated, const glm::dvec3& lo,
                                   const glm::dvec3& hi) const {
  auto world = [](const Slot& sl, int i) {
    const glm::vec3& q = sl.position[i];
    return glm::dvec3(sl.origin.x + q.x, sl.origin.y + q.y, q.z);
  };
  // Flagged probes: each slot keeps their short list.
  ProbeRef best;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used) continue;
    for (uint8_t i : sl.designated) {
      if (sl.interior[i] != index) continue;
      const glm::dvec3 d = world(sl, i) - designated;
      if (glm::dot(d, d) < best_d2) best_d2 = glm::dot(d, d), best = {int(s), i};
    }
  }
  if (best.valid()) return best;
  // Else the nearest probe inside the box, visiting only slots whose bounds meet it.
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used || sl.count == 0) continue;
    const glm::dvec3 slo(sl.origin.x + sl.lo.x, sl.origin.y + sl.lo.y, sl.lo.z);
    const glm::dvec3 shi(sl.origin.x + sl.hi.x, sl.origin.y + sl.hi.y, sl.hi.z);
    if (glm::any(glm::greaterThan(slo, hi)) || glm::any(glm::lessThan(shi, lo))) continue;
    for (int i = 0; i < sl.count; ++i) {
      if ((sl.flags[i] & kProbeInterior) && sl.interior[i] == index) continue;  // none, or found above
      if (sl.flags[i] & kProbeLightSource) continue;                          // read by no lookup
      const glm::dvec3 w = world(sl, i);
      if (!glm::all(glm::greaterThanEqual(w, lo)) || !glm::all(glm::lessThanEqual(w, hi))) continue;
      const glm::dvec3 d = w - designated;
      if (glm::dot(d, d) < best_d2) best_d2 = glm::dot(d, d), best = {int(s), i};
    }
  }
  return best;
}

ProbeRef ProbeCache::nearestProbe(const glm::dvec3& pos) const {
  ProbeRef best;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used) continue;
    for (int i = 0; i < sl.count; ++i) {
      if (sl.flags[size_t(i)] & kProbeLightSource) continue;  // read by no lookup
      const glm::dvec3 d = worldPosition({int(s), i}) - pos;
      const double d2 = glm::dot(d, d);
      if (d2 < best_d2) best_d2 = d2, best = {int(s), i};
    }
  }
  return best;
}

}  // namespace drtv::runtime
