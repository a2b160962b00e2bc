// The nearest-visible-probe index grid (see index_grid.h).
#include "drtv/baker/index_grid.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

namespace drtv::baker {
namespace {
// The visibility segment stops this short of the probe: a probe is lifted above a surface and
// never sits within 5 cm of one.
constexpr float kProbeClearanceM = 0.05f;
constexpr float kBelowM = 2.f, kAboveM = 4.f;
// `unresolved` marks: 1 = no probe visible, kInsideCell = centre inside geometry.
constexpr uint8_t kInsideCell = 2;
}  // namespace

void chooseGridExtent(std::span<const glm::vec3> probes, float ground_min_z, IndexGrid& grid) {
  float lo = std::isfinite(ground_min_z) ? ground_min_z : INFINITY, hi = -INFINITY;
  for (const glm::vec3& p : probes) {
    lo = std::min(lo, p.z);
    hi = std::max(hi, p.z);
  }
  if (!std::isfinite(lo)) lo = 0.f;
  if (!std::isfinite(hi)) hi = lo;
  lo -= kBelowM;
  hi += kAboveM;
  grid.z_min_m = std::floor(lo);
  grid.cell_height_m = std::max(kMinCellHeightM, (hi - grid.z_min_m) / float(kGridDim));
}

void fillIndexGrid(const raytrace::RayScene& scene, std::span<const glm::vec3> probes, const IndexGridSettings& settings,
                   IndexGrid& grid, IndexGridStats& stats, const IndexGridInteriors& interiors, const IndexGridSides& sides) {
  DRTV_CHECK_LE(probes.size(), size_t(kMaxProbesPerSector));
  DRTV_CHECK(interiors.probe_interior.empty() || interiors.probe_interior.size() == probes.size());
  for (const uint16_t n : interiors.probe_interior) DRTV_CHECK_LE(size_t(n), interiors.boxes.size());
  grid.cells.fill(kNoProbe);
  if (probes.empty()) return;
  // The interiors each probe lies in: its own (a designated probe's) and every box that holds its
  // position (a room's lattice probes, which name no interior).
  std::vector<std::vector<uint32_t>> probe_boxes(probes.size());
  if (!interiors.probe_interior.empty())
    for (size_t i = 0; i < probes.size(); ++i)
      for (size_t j = 0; j < interiors.boxes.size(); ++j)
        if (interiors.probe_interior[i] == j + 1u || interiors.boxes[j].contains(probes[i])) probe_boxes[i].push_back(uint32_t(j));
  // Whether probe i lies inside an interior whose box does not hold c (index_grid.h).
  auto inOtherInterior = [&](const glm::vec3& c, size_t i) {
    for (const uint32_t j : probe_boxes[i])
      if (!interiors.boxes[j].contains(c)) return true;
    return false;
  };
  // Whether c is inside geometry, by one ray up in a fixed oblique direction: from a point of a
  // regular lattice it runs through no other lattice point and along no lattice edge (the slopes
  // are irrational to float precision), so no kernel's tie-breaking at a vertex decides it.
  const glm::vec3 oblique = glm::normalize(glm::vec3(0.2718281f, 0.1414213f, 1.f));
  auto insideGeometry = [&](const glm::vec3& c, uint64_t& n_rays) {
    const raytrace::Ray ray{c, 0.f, oblique, 1e4f};
    const raytrace::Hit h = scene.intersect(ray);
    ++n_rays;
    return h.hit() && !scene.frontFace(ray, h.prim);
  };
  const size_t k = std::min(probes.size(), size_t(std::max(1, settings.visibility_candidates)));
  std::atomic<uint64_t> rays{0};
  std::atomic<size_t> nearest{0}, farther{0}, inside{0}, unseen{0}, searched{0}, other_side{0};
  DRTV_CHECK(sides.probe_covered.empty() || sides.probe_covered.size() == probes.size());
  const bool sided = settings.same_side && !sides.probe_covered.empty() && bool(sides.covered);
  // Cells that see no probe at all (enclosed air, a slit): they take a neighbour's choice below.
  std::vector<uint8_t> unresolved(grid.cells.size(), 0);
  // Probe coordinates as separate arrays, so that each cell's distances are one vectorised loop.
  const size_t P = probes.size();
  std::vector<float> px(P), py(P), pz(P);
  for (size_t i = 0; i < P; ++i) {
    px[i] = probes[i].x;
    py[i] = probes[i].y;
    pz[i] = probes[i].z;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, kGridDim), [&](const tbb::blocked_range<int>& zr) {
    std::vector<std::pair<float, uint32_t>> order(k);
    std::vector<float> dist2(P);
    uint64_t n_rays = 0;
    size_t n_nearest = 0, n_farther = 0, n_inside = 0, n_unseen = 0, n_searched = 0, n_other_side = 0;
    for (int z = zr.begin(); z < zr.end(); ++z)
      for (int y = 0; y < kGridDim; ++y)
        for (int x = 0; x < kGridDim; ++x) {
          const glm::vec3 c(float((x + 0.5) * kGridCellSizeM), float((y + 0.5) * kGridCellSizeM),
                            grid.z_min_m + (float(z) + 0.5f) * grid.cell_height_m);
          uint32_t chosen = 0;
          bool found = false, inside = false;
          size_t* counted = nullptr;  // the counter the cell's resolution went to
          // The probes of one side of the sky line (side 0 open, 1 covered), or all (side -1).
          auto select = [&](int side) {
            auto ok = [&](size_t i) { return side < 0 || int(sides.probe_covered[i]) == side; };
            // The k nearest, by insertion (k <= 16 of <= 255): ties broken by index, deterministic.
            size_t n = 0;
            for (size_t i = 0; i < P; ++i) {
              if (!ok(i) || (n == k && !(dist2[i] < order[k - 1].first))) continue;  // ties keep the lower index
              const std::pair<float, uint32_t> e{dist2[i], uint32_t(i)};
              size_t j = n < k ? n++ : k - 1;
              for (; j > 0 && e < order[j - 1]; --j) order[j] = order[j - 1];
              order[j] = e;
            }
            if (n == 0) return;
            chosen = order[0].second;
            for (size_t j = 0; j < n && !found; ++j) {
              const glm::vec3 to = probes[order[j].second] - c;
              const float dist = std::sqrt(order[j].first);
              if (dist <= kProbeClearanceM) {
                chosen = order[j].second;
                found = true;
                ++*(counted = j == 0 ? &n_nearest : &n_farther);
                break;
              }
              const raytrace::Ray ray{c, 0.f, to / dist, dist - kProbeClearanceM};
              const raytrace::Hit h = scene.intersect(ray);
              ++n_rays;
              if (!h.hit()) {
                chosen = order[j].second;
                found = true;
                ++*(counted = j == 0 ? &n_nearest : &n_farther);
              } else if (j == 0 && !scene.frontFace(ray, h.prim)) {
                // Centre inside geometry: a resolved neighbour's choice (below), or the nearest.
                (settings.inside_from_neighbours ? inside : found) = true;
                ++n_inside;
                break;
              }
            }
            if (!found && !inside && settings.search_beyond) {
              // None of the k nearest is visible: search the rest, nearest first, before falling
              // back (a cell must not name a probe behind a wall when one it can see exists).
              std::vector<std::pair<float, uint32_t>> rest;
              for (size_t i = 0; i < P; ++i)
                if (ok(i) && std::find_if(order.begin(), order.begin() + std::ptrdiff_t(n), [&](const auto& o) { return o.second == i; }) ==
                                 order.begin() + std::ptrdiff_t(n))
                  rest.push_back({dist2[i], uint32_t(i)});
              std::sort(rest.begin(), rest.end());
              for (const auto& [d2, i] : rest) {
                const float dist = std::sqrt(d2);
                const raytrace::Ray ray{c, 0.f, (probes[i] - c) / dist, dist - kProbeClearanceM};
                ++n_rays;
                if (dist <= kProbeClearanceM || !scene.intersect(ray).hit()) {
                  chosen = i;
                  found = true;
                  ++*(counted = &n_searched);
                  break;
                }
              }
            }
          };
          // Same rounding as glm::dot(d, d) of d = probe - c: ((dx*dx + dy*dy) + dz*dz).
          for (size_t i = 0; i < P; ++i) {
            const float dx = px[i] - c.x, dy = py[i] - c.y, dz = pz[i] - c.z;
            dist2[i] = dx * dx + dy * dy + dz * dz;
          }
          if (sided) {
            const int side = sides.covered(c, n_rays) ? 1 : 0;
            select(side);
            if (!found && !inside) {
              select(-1);
              n_other_side += found;
            }
          } else {
            select(-1);
          }
          // Two outcomes a crack in the first ray's test (index_grid.h) can give a cell inside
          // geometry: it reached an interior's probe from outside the interior's box, or it saw
          // no probe (its first ray met a front face beyond the crack). Either is asked once more,
          // by the oblique ray; inside, the cell takes the cell above, as its first ray should
          // have said.
          const bool doubtful = found ? inOtherInterior(c, chosen) : !inside && settings.search_beyond;
          if (settings.inside_from_neighbours && doubtful && insideGeometry(c, n_rays)) {
            if (found) --*counted;
            found = false, inside = true;
            ++n_inside;
          }
          if (inside) {
            unresolved[IndexGrid::cellIndex(x, y, z)] = kInsideCell;  // search_beyond or not: never a hidden probe
          } else if (!found) {
            ++n_unseen;
            unresolved[IndexGrid::cellIndex(x, y, z)] = settings.search_beyond;
          }
          grid.cells[IndexGrid::cellIndex(x, y, z)] = uint8_t(chosen);
        }
    rays += n_rays;
    nearest += n_nearest;
    farther += n_farther;
    inside += n_inside;
    unseen += n_unseen;
    searched += n_searched;
    other_side += n_other_side;
  });
  // A cell inside geometry takes the choice of the first resolved cell above it in its column:
  // under terrain or a floor that is the air just over the surface, on the same side of every
  // wall (a texel under the ground beside a room then repeats the outside, not the room).
  for (int y = 0; y < kGridDim; ++y)
    for (int x = 0; x < kGridDim; ++x) {
      int above = -1;  // the choice of the nearest resolved cell above, if any
      for (int z = kGridDim - 1; z >= 0; --z) {
        const size_t i = IndexGrid::cellIndex(x, y, z);
        if (!unresolved[i])
          above = grid.cells[i];
        else if (unresolved[i] == kInsideCell && above >= 0) {
          grid.cells[i] = uint8_t(above);
          unresolved[i] = 0;
        }
      }
    }
  // A cell no probe is visible from takes the choice of the nearest resolved cell along the grid
  // (breadth-first over the 6 face neighbours, in index order: deterministic): light from where
  // it is, not from the nearest probe, which may be on the far side of a wall. A sector where no
  // cell resolves keeps the nearest.
  {
    std::vector<int> frontier, next;
    for (int i = 0; i < int(grid.cells.size()); ++i)
      if (!unresolved[size_t(i)]) frontier.push_back(i);
    std::vector<uint8_t> done(unresolved.size());
    for (size_t i = 0; i < done.size(); ++i) done[i] = !unresolved[i];
    while (!frontier.empty()) {
      next.clear();
      for (const int i : frontier) {
        const int x = i % kGridDim, y = (i / kGridDim) % kGridDim, z = i / (kGridDim * kGridDim);
        const int nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z}, {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
        for (const auto& q : nb) {
          if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= kGridDim || q[1] >= kGridDim || q[2] >= kGridDim) continue;
          const size_t j = IndexGrid::cellIndex(q[0], q[1], q[2]);
          if (done[j]) continue;
          done[j] = 1;
          grid.cells[j] = grid.cells[size_t(i)];
          next.push_back(int(j));
        }
      }
      std::sort(next.begin(), next.end());
      frontier.swap(next);
    }
  }
  stats.rays += rays;
  stats.cells_nearest += nearest;
  stats.cells_farther += farther;
  stats.cells_inside += inside;
  stats.cells_unseen += unseen;
  stats.cells_searched += searched;
  stats.cells_other_side += other_side;
}

}  // namespace drtv::baker
