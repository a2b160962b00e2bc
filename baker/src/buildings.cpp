// The bake report per building (buildings.h).
#include "drtv/baker/buildings.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>
#include <tuple>
#include <unordered_map>

#include "drtv/formats/probe.h"
#include "drtv/formats/visibility.h"

namespace drtv::baker {
namespace {

// Union-find over probe indices.
struct Sets {
  std::vector<uint32_t> parent;
  explicit Sets(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void join(uint32_t a, uint32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// Probes per storey of one building, bottom up (buildings.h): each probe's rank in its column,
// where a stacked probe (kProbeStacked) keeps the rank of the probe under it.
struct ColumnProbe {
  glm::dvec3 position;
  bool stacked;
};
std::vector<size_t> storeys(std::vector<ColumnProbe> ps, const BuildingOptions& o) {
  const double q = std::max(o.column_m, 1e-3);
  auto column = [&](const glm::dvec3& p) { return std::pair(std::llround(p.x / q), std::llround(p.y / q)); };
  std::sort(ps.begin(), ps.end(), [&](const ColumnProbe& a, const ColumnProbe& b) {
    return std::tuple(column(a.position), a.position.z, a.stacked) < std::tuple(column(b.position), b.position.z, b.stacked);
  });
  std::vector<size_t> out;
  for (size_t i = 0, rank = 0; i < ps.size(); ++i) {
    const bool same = i > 0 && column(ps[i].position) == column(ps[i - 1].position);
    rank = same ? rank + (ps[i].stacked ? 0 : 1) : 0;
    if (rank == out.size()) out.push_back(0);
    ++out[rank];
  }
  // Every column holding a rank holds the ranks below it: the counts never rise. The top ranks
  // holding under `small_level` of the ground's probes fold into the rank below.
  while (out.size() > 1 && double(out.back()) < o.small_level * double(out.front())) {
    out[out.size() - 2] += out.back();
    out.pop_back();
  }
  return out;
}

}  // namespace

void BuildingCollector::addSector(const Sector& sector) {
  const glm::dvec3 origin(double(sector.key.ix) * kSectorSizeM, double(sector.key.iy) * kSectorSizeM, 0.0);
  for (const ProbeRecord& p : sector.probes) {
    if (!(p.flags & kProbeCovered)) continue;
    const uint16_t interior = (p.flags & kProbeInterior) ? p.interior : 0;
    probes_.push_back({origin + glm::dvec3(p.position[0], p.position[1], p.position[2]), interior, sector.key, (p.flags & kProbeStacked) != 0});
  }
}

std::vector<BuildingStats> BuildingCollector::buildings() const {
  // A sorted copy, so that the sectors' order does not matter.
  std::vector<Probe> ps = probes_;
  std::sort(ps.begin(), ps.end(), [](const Probe& a, const Probe& b) {
    return std::tie(a.position.x, a.position.y, a.position.z) < std::tie(b.position.x, b.position.y, b.position.z);
  });
  const double cell = std::max(options_.join_m, 1e-3);
  auto cellOf = [&](const glm::dvec3& p) { return std::pair<int64_t, int64_t>(int64_t(std::floor(p.x / cell)), int64_t(std::floor(p.y / cell))); };
  auto pack = [](int64_t x, int64_t y) { return (uint64_t(uint32_t(int32_t(x))) << 32) | uint32_t(int32_t(y)); };
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  for (uint32_t i = 0; i < ps.size(); ++i) {
    const auto [cx, cy] = cellOf(ps[i].position);
    grid[pack(cx, cy)].push_back(i);
  }
  Sets sets(ps.size());
  const double join2 = options_.join_m * options_.join_m;
  for (uint32_t i = 0; i < ps.size(); ++i) {
    const auto [cx, cy] = cellOf(ps[i].position);
    for (int64_t dy = -1; dy <= 1; ++dy)
      for (int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = grid.find(pack(cx + dx, cy + dy));
        if (it == grid.end()) continue;
        for (const uint32_t j : it->second) {
          if (j <= i) continue;
          const double ex = ps[i].position.x - ps[j].position.x, ey = ps[i].position.y - ps[j].position.y;
          if (ex * ex + ey * ey <= join2) sets.join(i, j);
        }
      }
  }
  std::unordered_map<uint32_t, std::vector<uint32_t>> members;
  for (uint32_t i = 0; i < ps.size(); ++i) members[sets.find(i)].push_back(i);
  std::vector<BuildingStats> out;
  out.reserve(members.size());
  for (const auto& [root, idx] : members) {
    BuildingStats b;
    b.min = glm::dvec2(INFINITY);
    b.max = glm::dvec2(-INFINITY);
    b.bottom_z = INFINITY;
    b.top_z = -INFINITY;
    std::vector<ColumnProbe> at;
    std::set<uint16_t> rooms;
    std::set<SectorKey> keys;
    for (const uint32_t i : idx) {
      const Probe& p = ps[i];
      b.min = glm::min(b.min, glm::dvec2(p.position));
      b.max = glm::max(b.max, glm::dvec2(p.position));
      b.bottom_z = std::min(b.bottom_z, p.position.z);
      b.top_z = std::max(b.top_z, p.position.z);
      at.push_back({p.position, p.stacked});
      if (p.interior) rooms.insert(p.interior);
      keys.insert(p.key);
    }
    b.probes = idx.size();
    b.storey_probes = storeys(std::move(at), options_);
    b.rooms = rooms.size();
    b.bytes = b.probes * (sizeof(ProbeRecord) + kVisBytesPerProbe);
    b.sectors = int(keys.size());
    out.push_back(std::move(b));
  }
  std::sort(out.begin(), out.end(), [](const BuildingStats& a, const BuildingStats& b) {
    return std::tie(b.probes, a.min.x, a.min.y) < std::tie(a.probes, b.min.x, b.min.y);
  });
  return out;
}

}  // namespace drtv::baker
